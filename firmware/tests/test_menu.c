/*
  test_menu.c - walk the control panel menu ([CBR40] section V) with
  encoder and OK events on the panel's own channel: Laser -> On/Off ->
  confirm, Jog X, MBLA mode, Status; read the LCD back with $LCD. The same
  bytes on the serial line do nothing (the UTF-8 '²' case).
*/
#include <stdint.h>
#include <string.h>

#include "laser.h"
#include "menu.h"
#include "planner.h"
#include "protocol.h"
#include "serial.h"
#include "settings.h"
#include "shell_test.h"
#include "shell_util.h"
#include "status_codes.h"
#include "stepper.h"

static const char *send(const char *bytes) {
  shell_out_clear();
  shell_send(bytes);
  return shell_out();
}

#define CW "\xB0"
#define CCW "\xB1"
#define OK "\xB2"

/* Events from the panel (the board's encoder and button handlers), one per
   main-loop pass as a hand gives them, then the loop runs until quiet. */
static void panel(const char *events) {
  for (const char *p = events; *p; p++) {
    serial_panel_event((uint8_t)*p);
    protocol_poll();
  }
  shell_send("");
}

int main(int argc, char **argv) {
  (void)argc; (void)argv;
  shell_storage_clear();
  protocol_startup();

  /* start: top level, "Laser" selected */
  CHECK(menu_current() == MENU_LASER);
  CHECK_HAS(menu_lcd_line(0), "LABKIT-FW  MENU");
  CHECK_HAS(menu_lcd_line(1), "> Laser");
  for (int r = 0; r < LCD_ROWS; r++)
    CHECK(strlen(menu_lcd_line((uint8_t)r)) == LCD_COLS);

  /* the bytes of the panel's events on the serial line are not panel events:
     two UTF-8 '\xc2\xb2' in a comment once entered Laser and switched it on */
  const char *o = send("G21 (mm\xc2\xb2 \xc2\xb2)\n" OK OK CW OK OK "\n");
  CHECK(!strcmp(o, "ok\r\nok\r\n"));
  CHECK(menu_current() == MENU_LASER);
  CHECK(!menu_laser_is_on());
  CHECK(laser_current_duty() == 0);

  /* Laser -> On/Off: OK calls the object with "Off" chosen; OK on Off fires nothing */
  panel(OK);
  CHECK(menu_current() == MENU_LASER_ONOFF);
  CHECK_HAS(menu_lcd_line(0), "LASER ON/OFF");
  CHECK_HAS(menu_lcd_line(1), "Beam:  OFF");
  CHECK_HAS(menu_lcd_line(2), "> Off");
  panel(OK);
  CHECK(menu_current() == MENU_LASER);
  CHECK(!menu_laser_is_on() && laser_current_duty() == 0);
  /* two OKs are not enough: a turn to On, OK, and OK again on the confirm screen */
  panel(OK OK);
  CHECK(!menu_laser_is_on() && laser_current_duty() == 0);
  CHECK(menu_current() == MENU_LASER);
  panel(OK CW);
  CHECK_HAS(menu_lcd_line(2), "> On");
  panel(OK);
  CHECK(menu_current() == MENU_LASER_CONFIRM);
  CHECK_HAS(menu_lcd_line(0), "FIRE FOCUS BEAM?");
  CHECK(laser_current_duty() == 0);
  panel(CW);                                  /* a turn cancels */
  CHECK(menu_current() == MENU_LASER_ONOFF && laser_current_duty() == 0);
  panel(CW OK OK);                            /* On, ask, fire */
  CHECK(menu_current() == MENU_LASER);
  CHECK(menu_laser_is_on());
  CHECK(laser_current_duty() == MENU_FOCUS_DUTY);
  panel(OK);                                  /* back in: Off is chosen */
  CHECK_HAS(menu_lcd_line(1), "Beam:  ON");
  CHECK_HAS(menu_lcd_line(2), "> Off");
  panel(OK);
  CHECK(!menu_laser_is_on());
  CHECK(laser_current_duty() == 0);

  /* a status poll leaves the focus beam on; any host line (a blank one too),
     a hold, a reset switch it off */
  panel(OK CW OK OK);
  send("?");
  CHECK(menu_laser_is_on() && laser_current_duty() == MENU_FOCUS_DUTY);
  panel(OK OK);
  CHECK(!menu_laser_is_on() && laser_current_duty() == 0);
  static const char *const enders[] = {"G4 P0\n", "\n", "!", "\x18", "$C\n"};
  for (unsigned k = 0; k < sizeof enders / sizeof enders[0]; k++) {
    if (protocol_state() == PROTO_CHECK)
      send("$C\n");
    panel(OK CW OK OK);
    CHECK(laser_current_duty() == MENU_FOCUS_DUTY);
    send(enders[k]);
    CHECK(!menu_laser_is_on());
    CHECK(laser_current_duty() == 0);
    if (enders[k][0] == '!')
      send("~");                              /* GRBL holds at rest too: resume */
  }
  /* and cannot be fired in check mode, in an alarm or while held */
  CHECK(protocol_state() == PROTO_CHECK);
  panel(OK CW OK OK);
  CHECK(laser_current_duty() == 0 && !menu_laser_is_on());
  CHECK_HAS(menu_lcd_line(3), "refused");
  CHECK(menu_current() == MENU_LASER_ONOFF);
  panel(OK);                                  /* Off applied, back to the top */
  send("$C\n");
  protocol_alarm(2);
  panel(OK CW OK OK);
  CHECK(laser_current_duty() == 0 && !menu_laser_is_on());
  panel(OK);
  send("$X\n");
  CHECK(protocol_state() == PROTO_IDLE && menu_current() == MENU_LASER);

  /* turn to Jog X; each detent jogs 1 mm */
  panel(CW);
  CHECK(menu_current() == MENU_JOG_X);
  CHECK_HAS(menu_lcd_line(1), "> Jog X");
  panel(OK);
  CHECK(menu_current() == MENU_JOG_X_MM);
  CHECK_HAS(menu_lcd_line(0), "JOG X");
  panel(CW);
  panel(CW);
  float mm[3];
  st_get_position_mm(mm);
  CHECK(mm[0] > 1.999f && mm[0] < 2.001f);
  CHECK_HAS(menu_lcd_line(1), "X:  2.000");
  panel(CCW);
  st_get_position_mm(mm);
  CHECK(mm[0] > 0.999f && mm[0] < 1.001f);
  panel(OK);
  CHECK(menu_current() == MENU_JOG_X);

  /* the host sees the panel's jogs: the parser follows the position */
  o = send("G91 G0 X1\n");
  CHECK_HAS(o, "ok");
  st_get_position_mm(mm);
  CHECK(mm[0] > 1.999f && mm[0] < 2.001f);

  /* MBLA mode: two detents on from Jog X (Jog Y, MBLA mode) */
  panel(CW CW);
  CHECK(menu_current() == MENU_MBLA);
  panel(OK);
  CHECK(menu_current() == MENU_MBLA_SET);
  CHECK_HAS(menu_lcd_line(1), "Now: GRBL");
  panel(CW CW);                                /* GRBL -> Fast -> Normal */
  CHECK_HAS(menu_lcd_line(2), "New: Normal");
  panel(CW);                                   /* HQ */
  panel(OK);
  CHECK(menu_current() == MENU_MBLA);
  CHECK(settings.planner == SET_PLANNER_MBLA && settings.mbla_mode == SET_MBLA_HQ);
  CHECK(plan_get_mode() == PLAN_MODE_HQ);
  panel(OK);
  CHECK_HAS(menu_lcd_line(1), "Now: HQ");
  panel(CCW CCW CCW OK);                       /* back to GRBL's junction planner */
  CHECK(plan_get_mode() == PLAN_MODE_JUNCTION);

  /* Status shows the position; $LCD prints the four lines */
  panel(CW);
  CHECK(menu_current() == MENU_STATUS);
  o = send("$LCD\n");
  CHECK_HAS(o, "[LCD:STATUS          ]");
  CHECK_HAS(o, "[LCD:X:2.00");
  CHECK_HAS(o, "[LCD:State:Idle");
  CHECK(count_of(o, "[LCD:") == 4);
  CHECK_HAS(o, "ok");

  /* the ring wraps: Status -> Laser */
  panel(CW);
  CHECK(menu_current() == MENU_LASER);
  panel(CCW);
  CHECK(menu_current() == MENU_STATUS);

  TEST_DONE("test_menu");
}
