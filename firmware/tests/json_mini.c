/* json_mini.c - see json_mini.h */
#include "json_mini.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
  const char *s;
  size_t i;
  char *err;
  size_t errlen;
  int failed;
} jm_p;

static void fail(jm_p *p, const char *msg)
{
  if (!p->failed) snprintf(p->err, p->errlen, "%s at byte %zu", msg, p->i);
  p->failed = 1;
}

static void ws(jm_p *p)
{
  while (p->s[p->i] == ' ' || p->s[p->i] == '\n' || p->s[p->i] == '\r' || p->s[p->i] == '\t') p->i++;
}

static jm_node_t *node(jm_type_t t)
{
  jm_node_t *n = calloc(1, sizeof *n);
  if (n) n->type = t;
  return n;
}

static void add(jm_node_t *parent, jm_node_t *child)
{
  parent->items = realloc(parent->items, (parent->n + 1) * sizeof *parent->items);
  parent->items[parent->n++] = child;
}

static char *read_string(jm_p *p)
{
  if (p->s[p->i] != '"') {
    fail(p, "expected a string");
    return NULL;
  }
  p->i++;
  size_t cap = 16, len = 0;
  char *out = malloc(cap);
  while (p->s[p->i] && p->s[p->i] != '"') {
    char c = p->s[p->i++];
    if (c == '\\') {
      char e = p->s[p->i++];
      switch (e) {
        case 'n': c = '\n'; break;
        case 't': c = '\t'; break;
        case 'r': c = '\r'; break;
        case 'b': c = '\b'; break;
        case 'f': c = '\f'; break;
        case 'u': {
          unsigned v = 0;
          for (int k = 0; k < 4; k++) {
            char h = p->s[p->i++];
            v = v * 16 + (unsigned)(h >= 'a' ? h - 'a' + 10 : h >= 'A' ? h - 'A' + 10 : h - '0');
          }
          c = v < 128 ? (char)v : '?';
          break;
        }
        default: c = e;
      }
    }
    if (len + 2 > cap) out = realloc(out, cap *= 2);
    out[len++] = c;
  }
  if (p->s[p->i] != '"') {
    fail(p, "unterminated string");
    free(out);
    return NULL;
  }
  p->i++;
  out[len] = 0;
  return out;
}

static jm_node_t *value(jm_p *p, int depth)
{
  ws(p);
  if (depth > 64) {
    fail(p, "nested too deep");
    return NULL;
  }
  char c = p->s[p->i];
  jm_node_t *n = NULL;
  if (c == '{' || c == '[') {
    int obj = c == '{';
    n = node(obj ? JM_OBJECT : JM_ARRAY);
    p->i++;
    ws(p);
    if (p->s[p->i] == (obj ? '}' : ']')) {
      p->i++;
      return n;
    }
    for (;;) {
      char *key = NULL;
      if (obj) {
        ws(p);
        key = read_string(p);
        if (!key) break;
        ws(p);
        if (p->s[p->i] != ':') {
          fail(p, "expected ':'");
          free(key);
          break;
        }
        p->i++;
      }
      jm_node_t *child = value(p, depth + 1);
      if (!child) {
        free(key);
        break;
      }
      child->key = key;
      add(n, child);
      ws(p);
      if (p->s[p->i] == ',') {
        p->i++;
        continue;
      }
      if (p->s[p->i] == (obj ? '}' : ']')) {
        p->i++;
        return n;
      }
      fail(p, "expected ',' or a closing bracket");
      break;
    }
    jm_free(n);
    return NULL;
  }
  if (c == '"') {
    char *s = read_string(p);
    if (!s) return NULL;
    n = node(JM_STRING);
    n->str = s;
    return n;
  }
  if (!strncmp(p->s + p->i, "true", 4) || !strncmp(p->s + p->i, "false", 5)) {
    n = node(JM_BOOL);
    n->boolean = p->s[p->i] == 't';
    p->i += n->boolean ? 4 : 5;
    return n;
  }
  if (!strncmp(p->s + p->i, "null", 4)) {
    p->i += 4;
    return node(JM_NULL);
  }
  if (c == '-' || (c >= '0' && c <= '9')) {
    size_t st = p->i;
    while (strchr("+-0123456789.eE", p->s[p->i]) && p->s[p->i]) p->i++;
    n = node(JM_NUMBER);
    n->str = malloc(p->i - st + 1);
    memcpy(n->str, p->s + st, p->i - st);
    n->str[p->i - st] = 0;
    n->num = strtod(n->str, NULL);
    return n;
  }
  fail(p, "unexpected character");
  return NULL;
}

jm_node_t *jm_parse(const char *text, char *err, size_t errlen)
{
  jm_p p = {text, 0, err, errlen, 0};
  jm_node_t *n = value(&p, 0);
  if (n) {
    ws(&p);
    if (p.s[p.i]) {
      fail(&p, "trailing characters");
      jm_free(n);
      return NULL;
    }
  }
  return n;
}

jm_node_t *jm_parse_file(const char *path, char *err, size_t errlen)
{
  FILE *f = fopen(path, "rb");
  if (!f) {
    snprintf(err, errlen, "cannot open %s", path);
    return NULL;
  }
  fseek(f, 0, SEEK_END);
  long len = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *buf = malloc((size_t)len + 1);
  size_t got = fread(buf, 1, (size_t)len, f);
  fclose(f);
  buf[got] = 0;
  jm_node_t *n = jm_parse(buf, err, errlen);
  free(buf);
  return n;
}

void jm_free(jm_node_t *n)
{
  if (!n) return;
  for (size_t i = 0; i < n->n; i++) jm_free(n->items[i]);
  free(n->items);
  free(n->key);
  free(n->str);
  free(n);
}

const jm_node_t *jm_get(const jm_node_t *obj, const char *key)
{
  if (!obj || obj->type != JM_OBJECT) return NULL;
  for (size_t i = 0; i < obj->n; i++)
    if (!strcmp(obj->items[i]->key, key)) return obj->items[i];
  return NULL;
}

const jm_node_t *jm_at(const jm_node_t *arr, size_t i)
{
  if (!arr || arr->type != JM_ARRAY || i >= arr->n) return NULL;
  return arr->items[i];
}

int64_t jm_int(const jm_node_t *n)
{
  if (!n || n->type != JM_NUMBER) return 0;
  return strtoll(n->str, NULL, 10);
}

double jm_num(const jm_node_t *n) { return (n && n->type == JM_NUMBER) ? n->num : 0.0; }
