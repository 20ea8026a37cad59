/*
  test_menu.c - walk the control panel menu ([CBR40] section V) with
  encoder and OK events: Laser -> On/Off, Jog X, MBLA mode, Status; read the
  LCD back with $LCD.
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

  /* Laser -> On/Off: OK calls the object, turn chooses, OK applies */
  send(OK);
  CHECK(menu_current() == MENU_LASER_ONOFF);
  CHECK_HAS(menu_lcd_line(0), "LASER ON/OFF");
  CHECK_HAS(menu_lcd_line(1), "Beam:  OFF");
  CHECK_HAS(menu_lcd_line(2), "> On");
  send(OK);                                   /* apply "On" */
  CHECK(menu_current() == MENU_LASER);
  CHECK(menu_laser_is_on());
  CHECK(laser_current_duty() == MENU_FOCUS_DUTY);
  send(OK);                                   /* back in: the choice is now Off */
  CHECK_HAS(menu_lcd_line(1), "Beam:  ON");
  CHECK_HAS(menu_lcd_line(2), "> Off");
  send(OK);
  CHECK(!menu_laser_is_on());
  CHECK(laser_current_duty() == 0);

  /* turn to Jog X; each detent jogs 1 mm */
  send(CW);
  CHECK(menu_current() == MENU_JOG_X);
  CHECK_HAS(menu_lcd_line(1), "> Jog X");
  send(OK);
  CHECK(menu_current() == MENU_JOG_X_MM);
  CHECK_HAS(menu_lcd_line(0), "JOG X");
  send(CW);
  send(CW);
  float mm[3];
  st_get_position_mm(mm);
  CHECK(mm[0] > 1.999f && mm[0] < 2.001f);
  CHECK_HAS(menu_lcd_line(1), "X:  2.000");
  send(CCW);
  st_get_position_mm(mm);
  CHECK(mm[0] > 0.999f && mm[0] < 1.001f);
  send(OK);
  CHECK(menu_current() == MENU_JOG_X);

  /* the host sees the panel's jogs: the parser follows the position */
  const char *o = send("G91 G0 X1\n");
  CHECK_HAS(o, "ok");
  st_get_position_mm(mm);
  CHECK(mm[0] > 1.999f && mm[0] < 2.001f);

  /* MBLA mode: two detents on from Jog X (Jog Y, MBLA mode) */
  send(CW CW);
  CHECK(menu_current() == MENU_MBLA);
  send(OK);
  CHECK(menu_current() == MENU_MBLA_SET);
  CHECK_HAS(menu_lcd_line(1), "Now: GRBL");
  send(CW CW);                                /* GRBL -> Fast -> Normal */
  CHECK_HAS(menu_lcd_line(2), "New: Normal");
  send(CW);                                   /* HQ */
  send(OK);
  CHECK(menu_current() == MENU_MBLA);
  CHECK(settings.planner == SET_PLANNER_MBLA && settings.mbla_mode == SET_MBLA_HQ);
  CHECK(plan_get_mode() == PLAN_MODE_HQ);
  send(OK);
  CHECK_HAS(menu_lcd_line(1), "Now: HQ");
  send(CCW CCW CCW OK);                       /* back to GRBL's junction planner */
  CHECK(plan_get_mode() == PLAN_MODE_JUNCTION);

  /* Status shows the position; $LCD prints the four lines */
  send(CW);
  CHECK(menu_current() == MENU_STATUS);
  o = send("$LCD\n");
  CHECK_HAS(o, "[LCD:STATUS          ]");
  CHECK_HAS(o, "[LCD:X:2.00");
  CHECK_HAS(o, "[LCD:State:Idle");
  CHECK(count_of(o, "[LCD:") == 4);
  CHECK_HAS(o, "ok");

  /* the ring wraps: Status -> Laser */
  send(CW);
  CHECK(menu_current() == MENU_LASER);
  send(CCW);
  CHECK(menu_current() == MENU_STATUS);

  TEST_DONE("test_menu");
}
