/*
  menu.h - the control panel of seed 004 ([CBR40] section V): a 4 x 16
  character LCD, a rotary encoder and an OK button.

  The menu is a table of objects (menu.c). Each object has its own screen
  (four lines of 16 characters) and knows what an encoder turn and an OK
  press do: move to a sibling, change its value, or call another object.

    Laser      --OK-->  On/Off      turn: choose On / Off (Off first), OK: Off
                                    applies, back; On asks:
                        Confirm     OK: fire the focus beam (only at rest:
                                    idle, nothing queued, no alarm, check
                                    mode or hold), back; turn: cancel
    Jog X      --OK-->  Jog X mm    turn: jog +-1 mm, OK: back
    Jog Y      --OK-->  Jog Y mm    turn: jog +-1 mm, OK: back
    MBLA mode  --OK-->  MBLA set    turn: GRBL / Fast / Normal / HQ, OK: store, back
    Status                          position and state; OK: refresh

  Events arrive through serial_panel_event() from the panel alone (the
  board's encoder / button handlers, the simulator's --panel channel with
  the bytes 0xB0 / 0xB1 / 0xB2), never from the serial line. The focus beam
  goes off on any host line, hold, reset, alarm or motion. `$LCD` prints the
  four lines as [LCD:...].
*/
#ifndef LK_MENU_H
#define LK_MENU_H

#include <stdint.h>

#define LCD_ROWS 4
#define LCD_COLS 16

/* Menu objects. */
enum {
  MENU_LASER, MENU_JOG_X, MENU_JOG_Y, MENU_MBLA, MENU_STATUS,   /* top level (a ring) */
  MENU_LASER_ONOFF, MENU_JOG_X_MM, MENU_JOG_Y_MM, MENU_MBLA_SET, MENU_LASER_CONFIRM,
  MENU_COUNT
};

/* Focus power of "Laser On" (duty of LK_LASER_PWM_TOP), a visible dot only. */
#define MENU_FOCUS_DUTY 10u
/* Panel jog: distance per detent, feed (mm/min). */
#define MENU_JOG_MM 1.0
#define MENU_JOG_FEED_MM_MIN 600.0

void menu_init(void);
void menu_event(uint8_t ev);        /* PANEL_CW / PANEL_CCW / PANEL_OK (main loop) */
void menu_task(void);               /* the menu machine: pops events, redraws */
uint8_t menu_current(void);
const char *menu_lcd_line(uint8_t row);   /* 16 characters, NUL-terminated */
void menu_report_lcd(void);         /* $LCD */
uint8_t menu_laser_is_on(void);
void menu_focus_off(void);          /* the panel's focus beam off (no-op when not on) */

#endif /* LK_MENU_H */
