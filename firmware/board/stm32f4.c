/*
  stm32f4.c - the hal of the labkit firmware on STM32F4 boards, registers
  written directly (no vendor library).

    BOARD_netduinoplus2  STM32F405 as QEMU models it (-M netduinoplus2):
                         host serial on USART1 (0x40011000, QEMU's first
                         -serial), a trace port on USART2 (second -serial),
                         TIM2 step timer. QEMU has no RCC or GPIO models:
                         nothing here waits on a ready bit, GPIO writes
                         go nowhere. QEMU clocks its timers at 1 GHz; the
                         prescaler below makes that the seed's 48 MHz.
    BOARD_nucleo_f446    Nucleo-F446RE: HSI 16 MHz -> PLL 48 MHz SYSCLK
                         (bounded waits on the ready bits), APB1 24 MHz,
                         host serial on USART2 (PA2/PA3, the ST-LINK
                         virtual COM port), TIM2 at 2 x APB1 = 48 MHz.

  Pins (both): steps PB0 PB1 PB2, directions PB3 PB4 PB5, laser gate PB6,
  laser PWM TIM3 CH1 (PA6, AF2, LK_LASER_PWM_TOP steps), e-stop input PC13
  (polled in hal_poll; the Nucleo's blue button). Step pulses are lowered
  by TIM2's compare channel 1 after step_pulse_us.
  Limit switches X Y Z on PB12 PB13 PB14 and the probe on PA7, the pins
  grblHAL's generic STM32F4xx map gives them (limits three adjacent pins of
  one port, read with one shift; PA7 is the Nucleo's D11 on the Arduino
  header). Inputs with pull-ups, GRBL's wiring: a normally open switch to
  ground reads low when pressed ($5 / $6 invert in limits.c). Limits are read
  by homing in the main loop, and their change (a press or a release) raises
  EXTI15_10, GRBL's hard-limit interrupt ($21=1, protocol_limit_pin_change);
  the probe is also read in the step interrupt while a G38.x runs. The QEMU
  build reads them as nothing pressed (below).

  Trace port (netduinoplus2 only): one byte per step tick on USART2,
  bits 0-2 steps X Y Z, bits 3-5 directions, bit 6 laser on. QEMU's
  character device takes it at any rate; tests count the steps.
*/
#include <stdint.h>

#include "config.h"
#include "hal.h"
#include "planner.h"
#include "protocol.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"
#include "laser.h"

#define REG(a) (*(volatile uint32_t *)(a))

/* RCC */
#define RCC_BASE 0x40023800u
#define RCC_CR REG(RCC_BASE + 0x00)
#define RCC_PLLCFGR REG(RCC_BASE + 0x04)
#define RCC_CFGR REG(RCC_BASE + 0x08)
#define RCC_AHB1ENR REG(RCC_BASE + 0x30)
#define RCC_APB1ENR REG(RCC_BASE + 0x40)
#define RCC_APB2ENR REG(RCC_BASE + 0x44)
#define FLASH_ACR REG(0x40023C00u)

/* GPIO */
#define GPIOA 0x40020000u
#define GPIOB 0x40020400u
#define GPIOC 0x40020800u
#define GPIO_MODER(p) REG((p) + 0x00)
#define GPIO_PUPDR(p) REG((p) + 0x0C)
#define GPIO_IDR(p) REG((p) + 0x10)
#define GPIO_BSRR(p) REG((p) + 0x18)
#define GPIO_AFRL(p) REG((p) + 0x20)

/* USART */
#define USART1 0x40011000u
#define USART2 0x40004400u
#define US_SR(u) REG((u) + 0x00)
#define US_DR(u) REG((u) + 0x04)
#define US_BRR(u) REG((u) + 0x08)
#define US_CR1(u) REG((u) + 0x0C)
#define SR_RXNE (1u << 5)
#define SR_TXE (1u << 7)
#define SR_ORE (1u << 3)
#define CR1_UE (1u << 13)
#define CR1_TE (1u << 3)
#define CR1_RE (1u << 2)
#define CR1_RXNEIE (1u << 5)

/* TIM2 (step timer), TIM3 (laser PWM) */
#define TIM2 0x40000000u
#define TIM3 0x40000400u
#define TIM_CR1(t) REG((t) + 0x00)
#define TIM_DIER(t) REG((t) + 0x0C)
#define TIM_SR(t) REG((t) + 0x10)
#define TIM_EGR(t) REG((t) + 0x14)
#define TIM_CCMR1(t) REG((t) + 0x18)
#define TIM_CCER(t) REG((t) + 0x20)
#define TIM_CNT(t) REG((t) + 0x24)
#define TIM_PSC(t) REG((t) + 0x28)
#define TIM_ARR(t) REG((t) + 0x2C)
#define TIM_CCR1(t) REG((t) + 0x34)

/* SYSCFG (EXTI line routing) and EXTI: the limit pins' change interrupt (hard limits) */
#define SYSCFG_EXTICR4 REG(0x40013800u + 0x14)
#define EXTI_BASE 0x40013C00u
#define EXTI_IMR REG(EXTI_BASE + 0x00)
#define EXTI_RTSR REG(EXTI_BASE + 0x08)
#define EXTI_FTSR REG(EXTI_BASE + 0x0C)
#define EXTI_PR REG(EXTI_BASE + 0x14)
#define LIMIT_LINES (7u << 12)     /* EXTI12..14: PB12..PB14 */
#define EXTI15_10_IRQ 40

/* Cortex-M */
#define NVIC_ISER(n) REG(0xE000E100u + 4u * (n))
#define NVIC_IPR(n) (*(volatile uint8_t *)(0xE000E400u + (n)))
#define SYST_CSR REG(0xE000E010u)
#define SYST_RVR REG(0xE000E014u)
#define SYST_CVR REG(0xE000E018u)

#ifdef BOARD_netduinoplus2
#define HOST_UART USART1
#define HOST_IRQ 37
#define CPU_HZ 168000000u          /* QEMU's netduinoplus2 system clock */
#define APB_UART_HZ 84000000u
#define TIM_HW_PSC 20u             /* QEMU timers count at 1 GHz: 1e9 / 21 = 47.6 MHz */
#define TRACE_UART USART2
/* Under QEMU 7.2 the TIM2 update interrupt was taken only when another
   interrupt (a UART byte) arrived, so motion crawled; its timer model
   re-arms from a counter that never wraps. In QEMU the step ticks
   therefore come from SysTick (168 MHz CPU clock, a 24-bit reload): same
   st_tick(), same periods, converted from the 48 MHz step clock to CPU
   cycles. */
#define QEMU_SYSTICK_STEPPER 1
#else
#define HOST_UART USART2
#define HOST_IRQ 38
#define CPU_HZ 48000000u
#define APB_UART_HZ 24000000u      /* USART2 on APB1 */
#define TIM_HW_PSC 0u              /* TIM2 clock 2 x APB1 = 48 MHz */
#endif
#define BAUD 115200u

static volatile uint32_t millis;
static volatile uint32_t irq_depth;
static uint8_t dir_now;
static uint16_t laser_duty_now;

/* Settings storage: a RAM page that survives a reset (flash sectors are a
   later step: on the board the settings are lost at power-off). */
__attribute__((section(".noinit"))) static uint8_t storage[1024];
__attribute__((section(".noinit"))) static uint32_t storage_len;

/* ---------------------------------------------------------------- clocks */

static void clocks_init(void) {
#ifdef BOARD_nucleo_f446
  /* HSI 16 MHz / M 16 * N 192 / P 4 = 48 MHz; bounded waits only. */
  FLASH_ACR = (FLASH_ACR & ~0xFu) | 1u;          /* 1 wait state at 48 MHz */
  RCC_PLLCFGR = 16u | (192u << 6) | (1u << 16) | (4u << 24);   /* P=4 (01), Q=4 */
  RCC_CR |= 1u << 24;                            /* PLL on */
  for (uint32_t i = 0; i < 100000u && !(RCC_CR & (1u << 25)); i++) {
  }
  /* SYSCLK = PLL; APB1 / 2 = 24 MHz (its limit is 45 MHz), so TIM2 runs at
     2 x 24 = 48 MHz; AHB and APB2 / 1 */
  RCC_CFGR = (RCC_CFGR & ~(3u | (7u << 10) | (7u << 13) | (0xFu << 4))) | 2u | (4u << 10);
  for (uint32_t i = 0; i < 100000u && (RCC_CFGR & 0xCu) != 0x8u; i++) {
  }
#endif
  RCC_AHB1ENR |= 0x7u;                           /* GPIO A B C */
  RCC_APB1ENR |= (1u << 0) | (1u << 1) | (1u << 17);   /* TIM2 TIM3 USART2 */
  RCC_APB2ENR |= (1u << 4) | (1u << 14);        /* USART1, SYSCFG */
}

static void gpio_init(void) {
  /* PB0..PB6 outputs */
  GPIO_MODER(GPIOB) = (GPIO_MODER(GPIOB) & ~0x3FFFu) | 0x1555u;
  GPIO_BSRR(GPIOB) = 0x7Fu << 16;                /* all low: no step, beam gate closed */
  /* PA6 AF2 (TIM3 CH1), PA2 PA3 AF7 (USART2) */
  GPIO_MODER(GPIOA) = (GPIO_MODER(GPIOA) & ~((3u << 12) | (3u << 4) | (3u << 6))) |
                      (2u << 12) | (2u << 4) | (2u << 6);
  GPIO_AFRL(GPIOA) = (GPIO_AFRL(GPIOA) & ~((0xFu << 24) | (0xFFu << 8))) | (2u << 24) | (0x77u << 8);
  /* PC13 input (reset state) */
  /* limits PB12..PB14 and probe PA7: inputs (MODER 00), pull-up (PUPDR 01) */
  GPIO_MODER(GPIOB) &= ~(0x3Fu << 24);
  GPIO_PUPDR(GPIOB) = (GPIO_PUPDR(GPIOB) & ~(0x3Fu << 24)) | (0x15u << 24);
  GPIO_MODER(GPIOA) &= ~(3u << 14);
  GPIO_PUPDR(GPIOA) = (GPIO_PUPDR(GPIOA) & ~(3u << 14)) | (1u << 14);
  /* GRBL's limit pin-change interrupt: EXTI12..14 from port B, on both edges (a press and a
     release are both changes); protocol_limit_pin_change() decides ($21, the state) */
  SYSCFG_EXTICR4 = (SYSCFG_EXTICR4 & ~0xFFFu) | 0x111u;
  EXTI_RTSR |= LIMIT_LINES;
  EXTI_FTSR |= LIMIT_LINES;
  EXTI_PR = LIMIT_LINES;
  EXTI_IMR |= LIMIT_LINES;
}

static void uart_init(uint32_t u, uint32_t clk_hz, int rx_irq) {
  US_BRR(u) = (clk_hz + BAUD / 2u) / BAUD;
  US_CR1(u) = CR1_UE | CR1_TE | CR1_RE | (rx_irq ? CR1_RXNEIE : 0u);
}

static void timers_init(void) {
  TIM_CR1(TIM2) = 0;
  TIM_PSC(TIM2) = TIM_HW_PSC;
  TIM_ARR(TIM2) = 0xFFFFu;
  TIM_EGR(TIM2) = 1u;                            /* load PSC */
  TIM_SR(TIM2) = 0;
  TIM_DIER(TIM2) = 1u | (1u << 1);               /* update + CC1 (pulse end) */
  /* laser PWM: TIM3 CH1 PWM mode 1, top LK_LASER_PWM_TOP */
  TIM_PSC(TIM3) = 0;
  TIM_ARR(TIM3) = LK_LASER_PWM_TOP - 1u;
  TIM_CCR1(TIM3) = 0;
  TIM_CCMR1(TIM3) = (6u << 4) | (1u << 3);
  TIM_CCER(TIM3) = 1u;
  TIM_CR1(TIM3) = 1u;
}

void board_init(void) {
  clocks_init();
  gpio_init();
  timers_init();
  SYST_RVR = CPU_HZ / 1000u - 1u;
  SYST_CVR = 0;
  SYST_CSR = 7u;                                 /* processor clock, interrupt, on */
  NVIC_IPR(28) = 0x00;                           /* step timer above everything */
  REG(0xE000ED20u) &= ~(0xFFu << 24);            /* SysTick priority 0 as well */
  NVIC_IPR(HOST_IRQ) = 0x40;
  /* the limit pins at the step timer's priority: neither interrupts the other, so the beam the
     pin interrupt switches off is not switched on again by a step interrupt it cut into */
  NVIC_IPR(EXTI15_10_IRQ) = 0x00;
  NVIC_ISER(EXTI15_10_IRQ / 32) = 1u << (EXTI15_10_IRQ % 32);
  NVIC_ISER(28 / 32) = 1u << (28 % 32);
  NVIC_ISER(HOST_IRQ / 32) = 1u << (HOST_IRQ % 32);
#ifdef TRACE_UART
  uart_init(TRACE_UART, 42000000u, 0);
#endif
  /* The UART last: from here on bytes are received; the banner follows. */
  uart_init(HOST_UART, APB_UART_HZ, 1);
}

void board_fault(void) {
  TIM_CR1(TIM2) = 0;
  TIM_CCR1(TIM3) = 0;
  GPIO_BSRR(GPIOB) = 1u << (6 + 16);
}

/* ---------------------------------------------------------------- interrupts */

#ifdef QEMU_SYSTICK_STEPPER
/* QEMU: SysTick is the step timer (see the top of this file). Reloads are
   counted in CPU cycles; milliseconds follow from them. */
static volatile uint8_t stepping;
static uint32_t st_cycles;        /* CPU cycles of the tick now running */
static uint32_t ms_cycles;        /* cycles towards the next millisecond */

static uint32_t step_cycles(uint32_t p) {
  const lk_machine_t *m = plan_machine();
  uint64_t c = (uint64_t)(p + 1u) * (m->prescaler + 1u) * (uint64_t)CPU_HZ / m->timer_clock_hz;
  return c < 64u ? 64u : c > 0xFFFFFFu ? 0xFFFFFFu : (uint32_t)c;
}

void SysTick_Handler(void) {
  if (!stepping) {
    millis++;
    return;
  }
  ms_cycles += st_cycles;
  while (ms_cycles >= CPU_HZ / 1000u) {
    ms_cycles -= CPU_HZ / 1000u;
    millis++;
  }
  st_tick();
}
#else
void SysTick_Handler(void) { millis++; }
#endif

void EXTI15_10_IRQHandler(void) {
  uint32_t pr = EXTI_PR & LIMIT_LINES;
  EXTI_PR = pr;                                  /* write 1 to clear */
  if (pr)
    protocol_limit_pin_change();
}

static void host_uart_irq(void) {
  uint32_t sr = US_SR(HOST_UART);
  if (sr & (SR_RXNE | SR_ORE))
    serial_rx_isr((uint8_t)US_DR(HOST_UART));
}
void USART1_IRQHandler(void) { host_uart_irq(); }
void USART2_IRQHandler(void) { host_uart_irq(); }

static uint32_t pulse_cycles;
#ifdef QEMU_SYSTICK_STEPPER
static uint32_t pending_period;
#endif

void TIM2_IRQHandler(void) {
  uint32_t sr = TIM_SR(TIM2);
  if (sr & 2u) {                                 /* CC1: end of the step pulse */
    TIM_SR(TIM2) = ~2u;
    GPIO_BSRR(GPIOB) = 0x7u << 16;
  }
  if (sr & 1u) {
    TIM_SR(TIM2) = ~1u;
    st_tick();
  }
}

/* ---------------------------------------------------------------- core hal */

void hal_set_dir(uint8_t bits) {
  dir_now = bits & 7u;
  GPIO_BSRR(GPIOB) = ((uint32_t)dir_now << 3) | ((uint32_t)(~dir_now & 7u) << (3 + 16));
}

void hal_step_pulse(uint8_t bits) {
  bits &= 7u;
  if (bits) {
    GPIO_BSRR(GPIOB) = bits;
    TIM_CCR1(TIM2) = pulse_cycles;
  }
#ifdef TRACE_UART
  US_DR(TRACE_UART) = (uint32_t)(bits | (dir_now << 3) | (laser_duty_now ? 0x40u : 0u));
#endif
}

#ifdef QEMU_SYSTICK_STEPPER
void hal_timer_set_period(uint32_t p) {
  st_cycles = step_cycles(p);
  if (stepping) {                 /* the tick that starts now: restart the count */
    SYST_RVR = st_cycles - 1u;
    SYST_CVR = 0;
  } else {
    pending_period = p;
  }
}

void hal_timer_start(void) {
  const lk_machine_t *m = plan_machine();
  pulse_cycles = (uint32_t)(m->step_pulse_us * (double)m->timer_clock_hz / 1e6 /
                            (double)(m->prescaler + 1u));
  st_cycles = step_cycles(pending_period);
  stepping = 1;
  SYST_RVR = st_cycles - 1u;
  SYST_CVR = 0;
}

void hal_timer_stop(void) {
  stepping = 0;
  SYST_RVR = CPU_HZ / 1000u - 1u;
}
#else
void hal_timer_set_period(uint32_t p) { TIM_ARR(TIM2) = p; }

void hal_timer_start(void) {
  const lk_machine_t *m = plan_machine();
  pulse_cycles = (uint32_t)(m->step_pulse_us * (double)m->timer_clock_hz / 1e6 /
                            (double)(m->prescaler + 1u));
  TIM_CNT(TIM2) = 0;
  TIM_SR(TIM2) = 0;
  TIM_CR1(TIM2) = 1u;
}

void hal_timer_stop(void) { TIM_CR1(TIM2) = 0; }
#endif

void hal_laser_set(uint16_t duty) {
  laser_duty_now = duty;
  TIM_CCR1(TIM3) = duty;
  GPIO_BSRR(GPIOB) = duty ? (1u << 6) : (1u << (6 + 16));   /* 0: the gate closes too */
}

void hal_laser_gate(uint32_t pwm_hz, uint16_t on_permille) {
  (void)pwm_hz;   /* pulsed mode: a second timer channel would switch the gate (not wired yet) */
  (void)on_permille;
}

void hal_air_set(uint8_t bits) { (void)bits; }

void hal_irq_disable(void) {
  __asm volatile("cpsid i" ::: "memory");
  irq_depth++;
}

void hal_irq_enable(void) {
  /* The ISB makes a pending interrupt be taken at once (QEMU only
     re-checks interrupts at the end of a translation block, which ISB
     forces; without it the step interrupt waited for the next UART byte). */
  if (irq_depth && --irq_depth == 0)
    __asm volatile("cpsie i\n isb" ::: "memory");
}

/* A low pin is a pressed switch (pull-up, switch to ground). QEMU models no
   GPIO: its input registers read 0, which would be every switch and the probe
   pressed (Pn:XYZP in every report), so the QEMU build reads nothing pressed. */
#ifdef QEMU_SYSTICK_STEPPER
uint8_t hal_limits_read(void) { return 0; }
uint8_t hal_probe_read(void) { return 0; }
#else
uint8_t hal_limits_read(void) { return (uint8_t)(~(GPIO_IDR(GPIOB) >> 12) & 7u); }
uint8_t hal_probe_read(void) { return (GPIO_IDR(GPIOA) & (1u << 7)) ? 0u : 1u; }
#endif

/* ---------------------------------------------------------------- shell hal */

uint32_t hal_millis(void) { return millis; }

void hal_serial_tx_kick(void) {
  int c;
  while ((US_SR(HOST_UART) & SR_TXE) && (c = serial_tx_pop()) >= 0)
    US_DR(HOST_UART) = (uint32_t)c;
}

void hal_serial_tx_wait(void) {
  while (!(US_SR(HOST_UART) & SR_TXE)) {
  }
  int c = serial_tx_pop();
  if (c >= 0)
    US_DR(HOST_UART) = (uint32_t)c;
}

void hal_poll(void) {
  if (serial_tx_count())
    hal_serial_tx_kick();
#ifdef BOARD_nucleo_f446
  /* e-stop: the blue button (PC13, low when pressed) */
  static uint8_t was;
  uint8_t now = !(GPIO_IDR(GPIOC) & (1u << 13));
  if (now && !was)
    protocol_estop();
  was = now;
#endif
}

uint8_t hal_storage_read(void *buf, uint32_t len) {
  if (storage_len != len || len > sizeof storage)
    return 0;
  for (uint32_t i = 0; i < len; i++)
    ((uint8_t *)buf)[i] = storage[i];
  return 1;
}

uint8_t hal_storage_write(const void *buf, uint32_t len) {
  if (len > sizeof storage)
    return 0;
  for (uint32_t i = 0; i < len; i++)
    storage[i] = ((const uint8_t *)buf)[i];
  storage_len = len;
  return 1;
}
