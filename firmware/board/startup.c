/*
  startup.c - Cortex-M4 vector table and reset handler (STM32F405 / F446).

  Reset: FPU on (CPACR) first, .data copied from flash, .bss zeroed, main().
  No clock is touched here and nothing waits on a ready bit (QEMU has no RCC
  model; board_init() configures what the board needs).
*/
#include <stdint.h>

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);

void Reset_Handler(void);
void Default_Handler(void);
void HardFault_Handler(void);
void SysTick_Handler(void);
void TIM2_IRQHandler(void);
void USART1_IRQHandler(void);
void USART2_IRQHandler(void);
void EXTI15_10_IRQHandler(void);

#define NVIC_IRQS 82

__attribute__((section(".isr_vector"), used))
void (*const vectors[16 + NVIC_IRQS])(void) = {
    [0] = (void (*)(void))(&_estack),
    [1] = Reset_Handler,
    [2] = Default_Handler,          /* NMI */
    [3] = HardFault_Handler,
    [4] = Default_Handler,          /* MemManage */
    [5] = Default_Handler,          /* BusFault */
    [6] = Default_Handler,          /* UsageFault */
    [11] = Default_Handler,         /* SVCall */
    [12] = Default_Handler,         /* DebugMon */
    [14] = Default_Handler,         /* PendSV */
    [15] = SysTick_Handler,
    [16 + 28] = TIM2_IRQHandler,
    [16 + 37] = USART1_IRQHandler,
    [16 + 38] = USART2_IRQHandler,
    [16 + 40] = EXTI15_10_IRQHandler,   /* limit switches PB12-PB14 (hard limits) */
};

void Reset_Handler(void) {
  *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20;   /* CPACR: CP10, CP11 full access */
  __asm volatile("dsb\n isb");
  uint32_t *src = &_sidata, *dst = &_sdata;
  while (dst < &_edata)
    *dst++ = *src++;
  for (dst = &_sbss; dst < &_ebss;)
    *dst++ = 0;
  (void)main();
  for (;;) {
  }
}

void Default_Handler(void) {
  for (;;) {
  }
}

/* A fault must leave the beam off: the board's fault handler cuts the laser. */
void board_fault(void);
void HardFault_Handler(void) {
  board_fault();
  for (;;) {
  }
}
