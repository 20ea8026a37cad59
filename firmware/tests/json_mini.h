/*
  json_mini.h - a small JSON reader for the firmware tests (not firmware code:
  it uses the heap). jm_parse() builds a tree; numbers keep their text so
  integers are read exactly and doubles by strtod (correctly rounded).
*/
#ifndef JSON_MINI_H
#define JSON_MINI_H

#include <stddef.h>
#include <stdint.h>

typedef enum { JM_NULL, JM_BOOL, JM_NUMBER, JM_STRING, JM_ARRAY, JM_OBJECT } jm_type_t;

typedef struct jm_node {
  jm_type_t type;
  char *key;             /* member name inside an object */
  char *str;             /* string value, or the text of a number */
  int boolean;
  double num;
  size_t n;              /* items of an array / members of an object */
  struct jm_node **items;
} jm_node_t;

jm_node_t *jm_parse(const char *text, char *err, size_t errlen);   /* NULL on error */
jm_node_t *jm_parse_file(const char *path, char *err, size_t errlen);
void jm_free(jm_node_t *n);
const jm_node_t *jm_get(const jm_node_t *obj, const char *key);     /* NULL when absent */
const jm_node_t *jm_at(const jm_node_t *arr, size_t i);
int64_t jm_int(const jm_node_t *n);
double jm_num(const jm_node_t *n);

#endif
