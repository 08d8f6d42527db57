/* YAML scene documents: a small tree of maps, sequences and scalars built from libyaml's
 * event stream, keeping the line and column of every node and map key so that every later
 * validation error can point into the file. */
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include <yaml.h>

#include "core_impl.h"

/* Deep enough for any scene; shallow enough that recursion cannot exhaust the stack on a
 * hostile file. */
#define EJ_YAML_MAX_DEPTH 128

typedef struct ej_yreader {
  yaml_parser_t parser;
  ej_doc *doc;
} ej_yreader;

static ej_loc ej_yaml_loc(const ej_yreader *r, yaml_mark_t mark)
{
  ej_loc loc = {r->doc->path, (int)mark.line + 1, (int)mark.column + 1};
  return loc;
}

static void ej_node_free(ej_node *n)
{
  if (!n) return;
  ej_free(n->text);
  for (int i = 0; i < n->n; ++i) {
    ej_node_free(n->items[i]);
    if (n->keys) ej_free(n->keys[i]);
  }
  ej_free(n->items);
  ej_free(n->keys);
  ej_free(n->key_locs);
  ej_free(n);
}

static ej_err ej_yaml_next(ej_yreader *r, yaml_event_t *ev)
{
  if (yaml_parser_parse(&r->parser, ev)) return EJ_OK;
  yaml_parser_t *p = &r->parser;
  if (p->error == YAML_MEMORY_ERROR) EJ_FAIL(EJ_ERR_MEM, "out of memory parsing YAML");
  ej_loc loc = ej_yaml_loc(r, p->problem_mark);
  if (p->error == YAML_READER_ERROR) {
    /* Reader errors (bad encoding, a control character) report a byte offset, not a line: the
     * line and column (counted in characters, a UTF-8 sequence being one) come from the text. */
    const char *t = r->doc->text;
    const size_t off = p->problem_offset < r->doc->text_len ? p->problem_offset : r->doc->text_len;
    int line = 1, col = 1;
    for (size_t k = 0; k < off; ++k) {
      if (t[k] == '\n') ++line, col = 1;
      else if (((unsigned char)t[k] & 0xC0u) != 0x80u) ++col; /* not a continuation byte */
    }
    loc.line = line, loc.col = col;
    return ej_error_input(&loc, "malformed YAML: %s (byte %zu; the scene must be UTF-8 text)",
                          p->problem ? p->problem : "unreadable input", p->problem_offset);
  }
  /* a tab where a token was expected (libyaml: "cannot start any token"): say what it is */
  const size_t at = p->problem_mark.index;
  const bool tab = at < r->doc->text_len && r->doc->text[at] == '\t' && !(p->problem && strstr(p->problem, "tab"));
  const char *hint = tab ? "; the character there is a tab: YAML indents with spaces, not tabs" : "";
  if (p->context)
    return ej_error_input(&loc, "malformed YAML: %s (%s at line %d)%s", p->problem ? p->problem : "syntax error",
                          p->context, (int)p->context_mark.line + 1, hint);
  return ej_error_input(&loc, "malformed YAML: %s%s", p->problem ? p->problem : "syntax error", hint);
}

static ej_err ej_node_new(ej_node_type type, ej_loc loc, ej_node **out)
{
  ej_node *n = ej_calloc(1, sizeof *n);
  EJ_ENSURE(n, EJ_ERR_MEM, "out of memory");
  n->type = type;
  n->loc = loc;
  *out = n;
  return EJ_OK;
}

/* Grows the item (and, for maps, key) arrays to hold one more entry. */
static ej_err ej_node_grow(ej_node *n, int *cap)
{
  if (n->n < *cap) return EJ_OK;
  int nc = *cap ? 2 * *cap : 8;
  ej_node **items = ej_realloc(n->items, (size_t)nc * sizeof *items);
  EJ_ENSURE(items, EJ_ERR_MEM, "out of memory");
  n->items = items;
  if (n->type == EJ_NODE_MAP) {
    char **keys = ej_realloc(n->keys, (size_t)nc * sizeof *keys);
    EJ_ENSURE(keys, EJ_ERR_MEM, "out of memory");
    n->keys = keys;
    ej_loc *kl = ej_realloc(n->key_locs, (size_t)nc * sizeof *kl);
    EJ_ENSURE(kl, EJ_ERR_MEM, "out of memory");
    n->key_locs = kl;
  }
  *cap = nc;
  return EJ_OK;
}

/* Anchors and aliases would make one scene location stand for several values and hide
 * where an error really is, so they are refused rather than expanded. */
static ej_err ej_yaml_check_anchor(ej_yreader *r, const yaml_event_t *ev)
{
  const yaml_char_t *anchor = NULL;
  if (ev->type == YAML_SCALAR_EVENT) anchor = ev->data.scalar.anchor;
  else if (ev->type == YAML_SEQUENCE_START_EVENT) anchor = ev->data.sequence_start.anchor;
  else if (ev->type == YAML_MAPPING_START_EVENT) anchor = ev->data.mapping_start.anchor;
  ej_loc loc = ej_yaml_loc(r, ev->start_mark);
  if (ev->type == YAML_ALIAS_EVENT)
    return ej_error_input(&loc, "YAML aliases (*%s) are not supported; write the value out in full",
                          (const char *)ev->data.alias.anchor);
  if (anchor)
    return ej_error_input(&loc, "YAML anchors (&%s) are not supported; write the value out in full",
                          (const char *)anchor);
  return EJ_OK;
}

static ej_err ej_yaml_node(ej_yreader *r, yaml_event_t *ev, int depth, ej_node **out);

static ej_err ej_yaml_scalar(ej_yreader *r, const yaml_event_t *ev, ej_node **out)
{
  ej_node *n = NULL;
  EJ_TRY(ej_node_new(EJ_NODE_SCALAR, ej_yaml_loc(r, ev->start_mark), &n));
  n->text = ej_malloc(ev->data.scalar.length + 1);
  if (!n->text) {
    ej_node_free(n);
    EJ_FAIL(EJ_ERR_MEM, "out of memory");
  }
  memcpy(n->text, ev->data.scalar.value, ev->data.scalar.length);
  n->text[ev->data.scalar.length] = '\0';
  const char *tag = (const char *)ev->data.scalar.tag;
  /* A quoted scalar (or one tagged !!str) is text even when it looks like a number. */
  n->quoted = ev->data.scalar.style == YAML_SINGLE_QUOTED_SCALAR_STYLE ||
              ev->data.scalar.style == YAML_DOUBLE_QUOTED_SCALAR_STYLE ||
              (tag && strcmp(tag, YAML_STR_TAG) == 0);
  *out = n;
  return EJ_OK;
}

static ej_err ej_yaml_seq(ej_yreader *r, const yaml_event_t *start, int depth, ej_node **out)
{
  ej_err rc = EJ_OK;
  ej_node *n = NULL;
  int cap = 0;
  EJ_TRY(ej_node_new(EJ_NODE_SEQ, ej_yaml_loc(r, start->start_mark), &n));
  for (;;) {
    yaml_event_t ev;
    EJ_TRY_GOTO(rc, ej_yaml_next(r, &ev), free_node);
    if (ev.type == YAML_SEQUENCE_END_EVENT) {
      yaml_event_delete(&ev);
      break;
    }
    ej_node *item = NULL;
    rc = ej_yaml_node(r, &ev, depth + 1, &item);
    yaml_event_delete(&ev);
    if (rc != EJ_OK) goto free_node;
    rc = ej_node_grow(n, &cap);
    if (rc != EJ_OK) {
      ej_node_free(item);
      goto free_node;
    }
    n->items[n->n++] = item;
  }
  *out = n;
  return EJ_OK;
free_node:
  ej_node_free(n);
  return rc;
}

static ej_err ej_yaml_map(ej_yreader *r, const yaml_event_t *start, int depth, ej_node **out)
{
  ej_err rc = EJ_OK;
  ej_node *n = NULL;
  int cap = 0;
  EJ_TRY(ej_node_new(EJ_NODE_MAP, ej_yaml_loc(r, start->start_mark), &n));
  for (;;) {
    yaml_event_t kev;
    EJ_TRY_GOTO(rc, ej_yaml_next(r, &kev), free_node);
    if (kev.type == YAML_MAPPING_END_EVENT) {
      yaml_event_delete(&kev);
      break;
    }
    ej_loc kloc = ej_yaml_loc(r, kev.start_mark);
    rc = ej_yaml_check_anchor(r, &kev);
    if (rc == EJ_OK && kev.type != YAML_SCALAR_EVENT)
      rc = ej_error_input(&kloc, "map keys must be plain names, not %s",
                          kev.type == YAML_MAPPING_START_EVENT ? "mappings" : "sequences");
    if (rc != EJ_OK) {
      yaml_event_delete(&kev);
      goto free_node;
    }
    const char *key = (const char *)kev.data.scalar.value;
    for (int i = 0; i < n->n; ++i) {
      if (strcmp(n->keys[i], key) == 0) {
        rc = ej_error_input(&kloc, "duplicate key '%s' (first at line %d)", key, n->key_locs[i].line);
        yaml_event_delete(&kev);
        goto free_node;
      }
    }
    char *kcopy = ej_strdup(key);
    yaml_event_delete(&kev);
    if (!kcopy) {
      rc = ej_error_push(EJ_ERR_MEM, __FILE__, __LINE__, __func__, "out of memory");
      goto free_node;
    }
    yaml_event_t vev;
    rc = ej_yaml_next(r, &vev);
    if (rc != EJ_OK) {
      ej_free(kcopy);
      goto free_node;
    }
    ej_node *val = NULL;
    rc = ej_yaml_node(r, &vev, depth + 1, &val);
    yaml_event_delete(&vev);
    if (rc == EJ_OK) rc = ej_node_grow(n, &cap);
    if (rc != EJ_OK) {
      ej_free(kcopy);
      ej_node_free(val);
      goto free_node;
    }
    n->keys[n->n] = kcopy;
    n->key_locs[n->n] = kloc;
    n->items[n->n++] = val;
  }
  *out = n;
  return EJ_OK;
free_node:
  ej_node_free(n);
  return rc;
}

/* Builds the node whose first event is ev (the caller deletes ev). */
static ej_err ej_yaml_node(ej_yreader *r, yaml_event_t *ev, int depth, ej_node **out)
{
  ej_loc loc = ej_yaml_loc(r, ev->start_mark);
  if (depth > EJ_YAML_MAX_DEPTH) return ej_error_input(&loc, "YAML nesting deeper than %d levels", EJ_YAML_MAX_DEPTH);
  EJ_TRY(ej_yaml_check_anchor(r, ev));
  switch (ev->type) {
  case YAML_SCALAR_EVENT: EJ_TRY(ej_yaml_scalar(r, ev, out)); return EJ_OK;
  case YAML_SEQUENCE_START_EVENT: EJ_TRY(ej_yaml_seq(r, ev, depth, out)); return EJ_OK;
  case YAML_MAPPING_START_EVENT: EJ_TRY(ej_yaml_map(r, ev, depth, out)); return EJ_OK;
  default: EJ_FAIL(EJ_ERR_INTERNAL, "unexpected YAML event %d", (int)ev->type);
  }
}

/* Parses doc->text into doc->root. */
static ej_err ej_doc_parse(ej_doc *doc)
{
  ej_err rc = EJ_OK;
  ej_yreader r = {.doc = doc};
  yaml_event_t ev;
  ej_loc file_loc = {doc->path, 0, 0};
  EJ_ENSURE(yaml_parser_initialize(&r.parser), EJ_ERR_MEM, "out of memory creating the YAML parser");
  yaml_parser_set_input_string(&r.parser, (const unsigned char *)doc->text, doc->text_len);

  EJ_TRY_GOTO(rc, ej_yaml_next(&r, &ev), delete_parser); /* stream start */
  yaml_event_delete(&ev);
  EJ_TRY_GOTO(rc, ej_yaml_next(&r, &ev), delete_parser);
  if (ev.type == YAML_STREAM_END_EVENT) {
    yaml_event_delete(&ev);
    rc = ej_error_input(&file_loc, "scene file is empty");
    goto delete_parser;
  }
  yaml_event_delete(&ev); /* document start */

  EJ_TRY_GOTO(rc, ej_yaml_next(&r, &ev), delete_parser);
  rc = ej_yaml_node(&r, &ev, 0, &doc->root);
  yaml_event_delete(&ev);
  if (rc != EJ_OK) goto delete_parser;
  if (doc->root->type == EJ_NODE_SCALAR && !doc->root->quoted && doc->root->text[0] == '\0') {
    rc = ej_error_input(&file_loc, "scene file is empty");
    goto free_root;
  }

  EJ_TRY_GOTO(rc, ej_yaml_next(&r, &ev), free_root); /* document end */
  yaml_event_delete(&ev);
  EJ_TRY_GOTO(rc, ej_yaml_next(&r, &ev), free_root);
  if (ev.type == YAML_DOCUMENT_START_EVENT) {
    ej_loc loc = ej_yaml_loc(&r, ev.start_mark);
    yaml_event_delete(&ev);
    rc = ej_error_input(&loc, "a scene file holds one YAML document; found a second one ('---')");
    goto free_root;
  }
  yaml_event_delete(&ev);
  yaml_parser_delete(&r.parser);
  return EJ_OK;

free_root:
  ej_node_free(doc->root);
  doc->root = NULL;
delete_parser:
  yaml_parser_delete(&r.parser);
  return rc;
}

ej_err ej_doc_parse_string(const char *name, const char *text, ej_doc **out)
{
  ej_err rc = EJ_OK;
  EJ_ENSURE(name && text && out, EJ_ERR_ARG, "NULL argument");
  ej_doc *doc = ej_calloc(1, sizeof *doc);
  EJ_ENSURE(doc, EJ_ERR_MEM, "out of memory");
  doc->path = ej_strdup(name);
  doc->text = ej_strdup(text);
  if (!doc->path || !doc->text) {
    rc = ej_error_push(EJ_ERR_MEM, __FILE__, __LINE__, __func__, "out of memory");
    goto free_doc;
  }
  doc->text_len = strlen(text);
  EJ_TRY_GOTO(rc, ej_doc_parse(doc), free_doc);
  *out = doc;
  return EJ_OK;
free_doc:
  ej_doc_destroy(doc);
  return rc;
}

/* Reads the whole file: the verbatim text goes into the output's /meta. */
static ej_err ej_doc_read(ej_doc *doc)
{
  ej_loc loc = {doc->path, 0, 0};
  FILE *f = fopen(doc->path, "rb");
  if (!f) return ej_error_input(&loc, "cannot open scene file: %s", strerror(errno));
  size_t cap = 4096, len = 0;
  char *buf = ej_malloc(cap);
  if (!buf) {
    fclose(f);
    EJ_FAIL(EJ_ERR_MEM, "out of memory");
  }
  for (;;) {
    if (len + 1 >= cap) {
      char *nb = ej_realloc(buf, cap * 2);
      if (!nb) {
        ej_free(buf);
        fclose(f);
        EJ_FAIL(EJ_ERR_MEM, "out of memory");
      }
      buf = nb;
      cap *= 2;
    }
    size_t got = fread(buf + len, 1, cap - 1 - len, f);
    len += got;
    if (got == 0) break;
  }
  if (ferror(f)) {
    int e = errno;
    ej_free(buf);
    fclose(f);
    return ej_error_input(&loc, "cannot read scene file: %s", strerror(e ? e : EIO));
  }
  fclose(f);
  buf[len] = '\0';
  doc->text = buf;
  doc->text_len = len;
  return EJ_OK;
}

ej_err ej_doc_load(const char *path, ej_doc **out)
{
  ej_err rc = EJ_OK;
  EJ_ENSURE(path && out, EJ_ERR_ARG, "NULL argument");
  ej_doc *doc = ej_calloc(1, sizeof *doc);
  EJ_ENSURE(doc, EJ_ERR_MEM, "out of memory");
  doc->path = ej_strdup(path);
  if (!doc->path) {
    rc = ej_error_push(EJ_ERR_MEM, __FILE__, __LINE__, __func__, "out of memory");
    goto free_doc;
  }
  EJ_TRY_GOTO(rc, ej_doc_read(doc), free_doc);
  EJ_TRY_GOTO(rc, ej_doc_parse(doc), free_doc);
  *out = doc;
  return EJ_OK;
free_doc:
  ej_doc_destroy(doc);
  return rc;
}

void ej_doc_destroy(ej_doc *doc)
{
  if (!doc) return;
  ej_node_free(doc->root);
  ej_free(doc->text);
  ej_free(doc->path);
  ej_free(doc);
}

static int ej_node_find(const ej_node *map, const char *key)
{
  if (!map || map->type != EJ_NODE_MAP || !key) return -1;
  for (int i = 0; i < map->n; ++i)
    if (strcmp(map->keys[i], key) == 0) return i;
  return -1;
}

const ej_node *ej_node_get(const ej_node *map, const char *key)
{
  int i = ej_node_find(map, key);
  return i < 0 ? NULL : map->items[i];
}

const ej_loc *ej_node_key_loc(const ej_node *map, const char *key)
{
  int i = ej_node_find(map, key);
  return i < 0 ? NULL : &map->key_locs[i];
}
