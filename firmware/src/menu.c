/*
  menu.c - the control panel menu as a table of objects ([CBR40] section V).
*/
#include "menu.h"

#include <string.h>

#include "gcode.h"
#include "laser.h"
#include "planner.h"
#include "protocol.h"
#include "report.h"
#include "serial.h"
#include "settings.h"
#include "status_codes.h"
#include "stepper.h"

typedef struct {
  const char *screen[LCD_ROWS];     /* its own graphical interface */
  void (*turn)(int8_t dir);         /* NULL: move to the next / previous sibling */
  void (*ok)(void);                 /* NULL: call the child object */
  uint8_t child;                    /* object OK calls (when ok == NULL) */
  uint8_t parent;                   /* object OK returns to from a child */
  void (*draw)(char lcd[LCD_ROWS][LCD_COLS + 1]);   /* dynamic fields, may be NULL */
} menu_obj_t;

static char lcd[LCD_ROWS][LCD_COLS + 1];
static uint8_t current;
static uint8_t laser_on, laser_choice;
static uint8_t mbla_choice;               /* 0 GRBL junction, 1 fast, 2 normal, 3 HQ */
static int32_t jog_count;
static uint8_t last_status;

static void go(uint8_t obj);

/* ---- actions */

static void laser_turn(int8_t dir) { (void)dir; laser_choice = !laser_choice; }

/* The beam may be fired for focusing only on a machine at rest that nothing
   else is commanding: idle, nothing queued, no alarm, check mode or hold. */
static uint8_t focus_allowed(void) {
  return st_is_idle() && plan_is_empty() && protocol_state() == PROTO_IDLE &&
         !protocol_hold_requested();
}

static void laser_ok(void) {
  if (!laser_choice)
    menu_focus_off();
  else if (!laser_on) {
    go(MENU_LASER_CONFIRM);        /* "On" asks once more before the beam comes on */
    return;
  }
  go(MENU_LASER);
}

static void confirm_cancel(int8_t dir) { (void)dir; go(MENU_LASER_ONOFF); }
static void confirm_ok(void) {
  if (!focus_allowed()) {
    go(MENU_LASER_ONOFF);
    last_status = STATUS_UNSUPPORTED_COMMAND;   /* shown as "refused: busy" */
    return;
  }
  laser_on = 1;                    /* before the output: the beam is never on unaccounted */
  laser_output(MENU_FOCUS_DUTY);
  go(MENU_LASER);
}

void menu_focus_off(void) {
  if (laser_on) {
    laser_on = 0;
    laser_off();
  }
}

static void jog_axis(char axis, int8_t dir) {
  char words[40];
  char num[16];
  fmt_float(num, sizeof num, dir * MENU_JOG_MM, 3);
  char feed[16];
  double f = MENU_JOG_FEED_MM_MIN;
  if (gc_get_dialect() == GC_DIALECT_LABKIT)
    f /= 60.0;
  fmt_float(feed, sizeof feed, f, 3);
  size_t k = 0;
  const char *parts[] = {"G91G21", (const char[]){axis, 0}, num, "F", feed};
  for (unsigned i = 0; i < 5; i++)
    for (const char *p = parts[i]; *p && k + 1 < sizeof words; p++)
      words[k++] = *p;
  words[k] = 0;
  menu_focus_off();                /* the focus beam is for a machine at rest */
  last_status = protocol_jog(words);
  if (last_status == STATUS_OK)
    jog_count += dir;
}
static void jog_x_turn(int8_t dir) { jog_axis('X', dir); }
static void jog_y_turn(int8_t dir) { jog_axis('Y', dir); }
static void back_to_parent(void) { go(0xFF); }

static void mbla_turn(int8_t dir) { mbla_choice = (uint8_t)((mbla_choice + 4 + dir) % 4); }
static void mbla_ok(void) {
  char line[8] = "204=0";
  line[4] = mbla_choice ? '1' : '0';
  last_status = STATUS_OK;
  if (!(plan_is_empty() && st_is_idle())) {
    last_status = STATUS_UNSUPPORTED_COMMAND;   /* only between jobs */
  } else {
    last_status = settings_store_setting(line);
    if (last_status == STATUS_OK && mbla_choice) {
      char l2[8] = "205=0";
      l2[4] = (char)('0' + mbla_choice - 1);
      last_status = settings_store_setting(l2);
    }
  }
  go(MENU_MBLA);
}

static void status_ok(void) { /* refresh */ }

/* ---- dynamic fields */

static void put(char row[LCD_COLS + 1], uint8_t col, const char *s) {
  while (*s && col < LCD_COLS)
    row[col++] = *s++;
}

static const char *mbla_name(uint8_t c) {
  static const char *const names[] = {"GRBL  ", "Fast  ", "Normal", "HQ    "};
  return names[c & 3u];
}

static uint8_t mbla_from_settings(void) {
  return settings.planner == SET_PLANNER_JUNCTION ? 0 : (uint8_t)(settings.mbla_mode + 1);
}

static void draw_top(char l[LCD_ROWS][LCD_COLS + 1]) {
  static const char *const names[] = {"Laser", "Jog X", "Jog Y", "MBLA mode", "Status"};
  for (uint8_t i = 0; i < 3; i++) {
    uint8_t item = (uint8_t)((current + i) % 5u);
    l[i + 1][0] = i == 0 ? '>' : ' ';
    put(l[i + 1], 2, names[item]);
  }
}

static void draw_laser(char l[LCD_ROWS][LCD_COLS + 1]) {
  put(l[1], 7, laser_on ? "ON " : "OFF");
  put(l[2], 0, laser_choice ? "> On    Off" : "  On  > Off");
  if (last_status != STATUS_OK)
    put(l[3], 0, "refused: busy   ");
}

static void draw_jog(char l[LCD_ROWS][LCD_COLS + 1]) {
  float mm[3];
  st_get_position_mm(mm);
  char num[16];
  uint8_t axis = current == MENU_JOG_X_MM ? 0 : 1;
  fmt_float(num, sizeof num, mm[axis], 3);
  put(l[1], 4, num);
  if (last_status != STATUS_OK)
    put(l[2], 0, "refused");
}

static void draw_mbla(char l[LCD_ROWS][LCD_COLS + 1]) {
  put(l[1], 5, mbla_name(mbla_from_settings()));
  put(l[2], 5, mbla_name(mbla_choice));
}

static void draw_status(char l[LCD_ROWS][LCD_COLS + 1]) {
  float mm[3];
  char num[16];
  st_get_position_mm(mm);
  fmt_float(num, sizeof num, mm[0], 2);
  put(l[1], 2, num);
  fmt_float(num, sizeof num, mm[1], 2);
  put(l[2], 2, num);
  const char *s = protocol_state() == PROTO_ALARM ? "Alarm" : st_is_idle() ? "Idle" : "Run";
  put(l[3], 6, s);
}

/* ---- the table */

static const menu_obj_t menu[MENU_COUNT] = {
    [MENU_LASER] = {{"LABKIT-FW  MENU", "", "", ""}, 0, 0, MENU_LASER_ONOFF, MENU_LASER, draw_top},
    [MENU_JOG_X] = {{"LABKIT-FW  MENU", "", "", ""}, 0, 0, MENU_JOG_X_MM, MENU_JOG_X, draw_top},
    [MENU_JOG_Y] = {{"LABKIT-FW  MENU", "", "", ""}, 0, 0, MENU_JOG_Y_MM, MENU_JOG_Y, draw_top},
    [MENU_MBLA] = {{"LABKIT-FW  MENU", "", "", ""}, 0, 0, MENU_MBLA_SET, MENU_MBLA, draw_top},
    [MENU_STATUS] = {{"STATUS", "X:", "Y:", "State:"}, 0, status_ok, 0, MENU_STATUS, draw_status},
    [MENU_LASER_ONOFF] = {{"LASER ON/OFF", "Beam:", "", "turn, OK=apply"}, laser_turn, laser_ok, 0,
                          MENU_LASER, draw_laser},
    [MENU_JOG_X_MM] = {{"JOG X  1mm/step", "X:", "", "OK = back"}, jog_x_turn, back_to_parent, 0,
                       MENU_JOG_X, draw_jog},
    [MENU_JOG_Y_MM] = {{"JOG Y  1mm/step", "Y:", "", "OK = back"}, jog_y_turn, back_to_parent, 0,
                       MENU_JOG_Y, draw_jog},
    [MENU_MBLA_SET] = {{"MBLA MODE", "Now:", "New:", "turn, OK=store"}, mbla_turn, mbla_ok, 0,
                       MENU_MBLA, draw_mbla},
    [MENU_LASER_CONFIRM] = {{"FIRE FOCUS BEAM?", "low power, idle", "OK again = fire", "turn = cancel"},
                            confirm_cancel, confirm_ok, 0, MENU_LASER_ONOFF, 0},
};

static void redraw(void) {
  const menu_obj_t *o = &menu[current];
  for (uint8_t r = 0; r < LCD_ROWS; r++) {
    memset(lcd[r], ' ', LCD_COLS);
    lcd[r][LCD_COLS] = 0;
    put(lcd[r], 0, o->screen[r]);
  }
  if (o->draw)
    o->draw(lcd);
}

static void go(uint8_t obj) {
  if (obj == 0xFF)
    obj = menu[current].parent;
  current = obj;
  if (current == MENU_LASER_ONOFF)
    laser_choice = 0;             /* "Off" first: "On" takes a turn and two OKs */
  if (current == MENU_MBLA_SET)
    mbla_choice = mbla_from_settings();
  if (current == MENU_JOG_X_MM || current == MENU_JOG_Y_MM || current == MENU_LASER_ONOFF)
    last_status = STATUS_OK;
}

void menu_init(void) {
  current = MENU_LASER;
  laser_on = laser_choice = mbla_choice = 0;
  jog_count = 0;
  last_status = STATUS_OK;
  redraw();
}

void menu_event(uint8_t ev) {
  const menu_obj_t *o = &menu[current];
  if (ev == PANEL_OK) {
    if (o->ok)
      o->ok();
    else
      go(o->child);
  } else if (ev == PANEL_CW || ev == PANEL_CCW) {
    int8_t dir = ev == PANEL_CW ? 1 : -1;
    if (o->turn)
      o->turn(dir);
    else if (current <= MENU_STATUS)
      current = (uint8_t)((current + 5 + dir) % 5u);
  }
  redraw();
}

void menu_task(void) {
  int ev;
  while ((ev = serial_panel_pop()) >= 0)
    menu_event((uint8_t)ev);
  /* the focus beam goes off as soon as the machine is not at rest (the
     protocol also switches it off on every host line, hold and stop) */
  if (laser_on && !focus_allowed())
    menu_focus_off();
  redraw();
}

uint8_t menu_current(void) { return current; }
const char *menu_lcd_line(uint8_t row) {
  redraw();                     /* reading the LCD shows what is true now */
  return row < LCD_ROWS ? lcd[row] : "";
}
uint8_t menu_laser_is_on(void) { return laser_on; }

void menu_report_lcd(void) {
  redraw();
  for (uint8_t r = 0; r < LCD_ROWS; r++) {
    serial_write("[LCD:");
    serial_write(lcd[r]);
    serial_write("]\r\n");
  }
}
