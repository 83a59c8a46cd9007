/*
 * scene.c - lexer and parser of lancer's scene format.
 *
 * The grammar is one level deep:
 *
 *     file      := statement*
 *     statement := KEYWORD [NAME] '{' property* '}'
 *     property  := KEY value*          (the KEY decides how many values)
 *     value     := NUMBER | NAME
 *
 * '#' starts a comment that runs to the end of the line. Each statement kind
 * has a table of its properties (Field), so one routine parses every block
 * and catches unknown, duplicate, missing and extra values in one place; the
 * per-kind code then only checks meaning. Every error goes through fail(),
 * which prefixes "file:line:col: ". Columns count bytes from 1.
 */
#include "lancer/scene.h"

#include <ctype.h>
#include <errno.h>
#include <stdint.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lancer/afile.h"
#include "lancer/image.h"
#include "bigmem.h"
#include "dvec.h"
#include "lex.h"

typedef struct {
    int line, col;
} Loc;

typedef enum { TOK_EOF, TOK_IDENT, TOK_NUMBER, TOK_STRING, TOK_LBRACE, TOK_RBRACE } TokKind;

typedef struct {
    TokKind kind;
    Loc loc;
    const char *start;
    size_t len;
    double num; /* numbers are read in double: the scene is kept as written */
} Token;

typedef struct {
    const char *name;
    const char *p, *end;
    Loc at; /* position of p */
    Token tok;
    char *err;
    size_t errlen;
    Scene *s;
    int cap_materials, cap_lights, cap_prims, cap_place, cap_patches, cap_ellipsoids, cap_ellipsoid_at;
    int have_image, have_camera, cap_keys;
    int *names, cap_names; /* the materials by name: open addressing, -1 free */
    uint64_t name_seed;    /* the table's hash seed (lex_hash_seed) */
    long long light_samples; /* of the lights so far (LIMIT_LIGHT_SAMPLES) */
} Parser;

LEX_PRINTF(3, 4) static int fail(Parser *P, Loc loc, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    lex_verror(P->err, P->errlen, P->name, loc.line, loc.col, fmt, ap);
    va_end(ap);
    return -1;
}

/* ---- lexer ---- */

static int is_ident_start(int c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
static int is_ident_char(int c) { return is_ident_start(c) || lex_is_digit(c); }

/* 1 when p, before end, ends a line: a newline, or a carriage return not
 * followed by one (old Mac OS files). */
static int line_end(const char *p, const char *end)
{
    return *p == '\n' || (*p == '\r' && (p + 1 >= end || p[1] != '\n'));
}

static void advance(Parser *P, size_t n)
{
    while (n-- > 0) {
        if (line_end(P->p, P->end)) {
            P->at.line++;
            P->at.col = 1;
        } else {
            P->at.col++;
        }
        P->p++;
    }
}

static int next(Parser *P)
{
    for (;;) { /* skip blanks and comments */
        while (P->p < P->end && (*P->p == ' ' || *P->p == '\t' || *P->p == '\r' || *P->p == '\n'))
            advance(P, 1);
        if (P->p < P->end && *P->p == '#') {
            while (P->p < P->end && !line_end(P->p, P->end))
                advance(P, 1);
            continue;
        }
        break;
    }
    Token *t = &P->tok;
    t->loc = P->at;
    t->start = P->p;
    t->len = 0;
    if (P->p >= P->end) {
        t->kind = TOK_EOF;
        return 0;
    }
    unsigned char c = (unsigned char)*P->p;
    if (c == '{' || c == '}') {
        t->kind = c == '{' ? TOK_LBRACE : TOK_RBRACE;
        t->len = 1;
        advance(P, 1);
        return 0;
    }
    if (is_ident_start(c)) {
        size_t n = 0;
        while (P->p + n < P->end && is_ident_char(P->p[n]))
            n++;
        t->kind = TOK_IDENT;
        t->len = n;
        advance(P, n);
        return 0;
    }
    size_t n = lex_number_len(P->p, P->end);
    if (n > 0) {
        size_t m = n;
        /* "1.2.3", "3x" and "1-2" are typos, not a number and something after it. */
        while (P->p + m < P->end && (is_ident_char(P->p[m]) || P->p[m] == '.' || P->p[m] == '+' || P->p[m] == '-'))
            m++;
        if (m != n)
            return fail(P, t->loc, "malformed number '%.*s'", (int)m, P->p);
        char buf[LIMIT_NUMBER_CHARS + 1];
        if (n >= sizeof buf)
            return fail(P, t->loc, "number longer than %d characters", LIMIT_NUMBER_CHARS);
        memcpy(buf, P->p, n);
        buf[n] = '\0';
        t->num = strtod(buf, NULL);
        if (!isfinite((float)t->num))
            return fail(P, t->loc, "non-finite number '%s' (out of single-precision range)", buf);
        t->kind = TOK_NUMBER;
        t->len = n;
        advance(P, n);
        return 0;
    }
    if (c == '"') { /* a string: to the closing quote on the same line; \" and \\ escape */
        size_t m = 1;
        while (P->p + m < P->end && P->p[m] != '"' && P->p[m] != '\n' && P->p[m] != '\r') {
            if (P->p[m] == '\\' && P->p + m + 1 < P->end && P->p[m + 1] != '\n' && P->p[m + 1] != '\r')
                m++;
            /* A NUL would cut the path short without a word ("ok.off\0x"
             * loaded ok.off); no control byte, tab and DEL included,
             * belongs in a path, and messages echo the path raw. */
            unsigned char b = (unsigned char)P->p[m];
            if (b < 0x20 || b == 0x7f) {
                Loc at = {t->loc.line, t->loc.col + (int)m};
                return fail(P, at, "byte 0x%02x in a string", b);
            }
            m++;
        }
        if (P->p + m >= P->end || P->p[m] != '"')
            return fail(P, t->loc, "unterminated string");
        t->kind = TOK_STRING;
        t->len = m + 1;
        advance(P, m + 1);
        return 0;
    }
    if (c >= 0x21 && c < 0x7f)
        return fail(P, t->loc, "unexpected character '%c'", c);
    return fail(P, t->loc, "unexpected byte 0x%02x", c);
}

static int tok_is(const Token *t, const char *word)
{
    LexTok w = {t->start, t->len};
    return t->kind == TOK_IDENT && lex_tok_is(w, word);
}

/* A quoted description of the current token, for messages. */
static const char *tok_desc(const Token *t, char *buf, size_t len)
{
    switch (t->kind) {
    case TOK_EOF:
        return "end of file";
    case TOK_LBRACE:
        return "'{'";
    case TOK_RBRACE:
        return "'}'";
    case TOK_NUMBER:
        snprintf(buf, len, "number '%.*s'", (int)t->len, t->start);
        return buf;
    case TOK_STRING:
        snprintf(buf, len, "string %.*s", (int)(t->len > 40 ? 40 : t->len), t->start);
        return buf;
    case TOK_IDENT:
        break;
    }
    snprintf(buf, len, "'%.*s'", (int)(t->len > 40 ? 40 : t->len), t->start);
    return buf;
}

static int is_keyword(const Token *t)
{
    static const char *const kw[] = {"image", "camera",          "light", "material", "sphere",      "plane",
                                     "triangle", "smooth_triangle", "box", "obox", "mesh", "pn_triangle", "keyframe"};
    for (size_t i = 0; i < sizeof kw / sizeof kw[0]; i++)
        if (tok_is(t, kw[i]))
            return 1;
    return 0;
}

/* q moved past blanks and comments, without reading tokens: a look ahead. */
static const char *past_blanks(const Parser *P, const char *q)
{
    for (;;) {
        while (q < P->end && (*q == ' ' || *q == '\t' || *q == '\n' || *q == '\r'))
            q++;
        if (q < P->end && *q == '#') /* to the line's end, a lone CR's too (lex.c) */
            while (q < P->end && *q != '\n' && *q != '\r')
                q++;
        else
            return q;
    }
}

/* 1 when the text after the current token opens a block: '{', or a name
 * and '{' (a material's), blanks and comments between. A statement's
 * keyword met inside a block is then the next statement, its block not
 * closed; else a property the block does not have. */
static int opens_block(const Parser *P)
{
    const char *q = P->p;
    for (int name = 0; name < 2; name++) {
        q = past_blanks(P, q);
        if (q < P->end && *q == '{')
            return 1;
        if (name || q >= P->end || !(isalpha((unsigned char)*q) || *q == '_'))
            return 0;
        while (q < P->end && (isalnum((unsigned char)*q) || *q == '_'))
            q++;
    }
    return 0;
}

/* 1 when the text after the current token begins a number or a string:
 * a value, where a name's key (material, pn_mode) is followed by another
 * key and its value, the name left out. */
static int value_follows(const Parser *P)
{
    const char *q = past_blanks(P, P->p);
    return q < P->end && (isdigit((unsigned char)*q) || *q == '-' || *q == '+' || *q == '.' || *q == '"');
}

/* ---- block parsing driven by field tables ---- */

/* F_SCALE: one number or three; F_MAT: twelve; F_STRING: a quoted string. */
typedef enum { F_NUM, F_PAIR, F_VEC, F_SCALE, F_MAT, F_FLAG, F_NAME, F_STRING } FieldKind;

typedef struct {
    const char *key;
    FieldKind kind;
} Field;

typedef struct {
    int set;
    Loc key, value; /* where the key and its first value stand */
    double v[12];
    int n; /* how many numbers were given */
    char name[SCENE_NAME_MAX];
    char str[SCENE_PATH_MAX];
} Value;

/* The transform keys every object takes, last in its table, in this order. */
#define XF_FIELDS {"matrix", F_MAT}, {"scale", F_SCALE}, {"rotate", F_VEC}, { "translate", F_VEC }
enum { XF_MATRIX, XF_SCALE, XF_ROTATE, XF_TRANSLATE, XF_N };

static const char *kind_desc(FieldKind k)
{
    switch (k) {
    case F_NUM:
        return "a number";
    case F_PAIR:
        return "two numbers";
    case F_VEC:
        return "three numbers";
    case F_SCALE:
        return "one or three numbers";
    case F_MAT:
        return "twelve numbers";
    case F_STRING:
        return "a quoted string";
    case F_NAME:
        return "a name";
    case F_FLAG:
        break;
    }
    return "no value";
}

static int find_field(const Field *f, int n, const Token *t)
{
    for (int i = 0; i < n; i++)
        if (tok_is(t, f[i].key))
            return i;
    return -1;
}

/* Reads a NAME token into out. */
static int read_name(Parser *P, char *out, const char *what)
{
    char buf[64];
    if (P->tok.kind != TOK_IDENT)
        return fail(P, P->tok.loc, "%s: expected a name, found %s", what, tok_desc(&P->tok, buf, sizeof buf));
    if (P->tok.len >= SCENE_NAME_MAX)
        return fail(P, P->tok.loc, "%s: name longer than %d characters", what, SCENE_NAME_MAX - 1);
    memcpy(out, P->tok.start, P->tok.len);
    out[P->tok.len] = '\0';
    return next(P);
}

/* Parses "{ property* }" for a block named `what`; the current token must be
 * the '{'. On return the token after '}' is current. */
static int parse_block(Parser *P, const char *what, const Field *f, int nf, Value *vals)
{
    char buf[64];
    memset(vals, 0, sizeof(Value) * (size_t)nf);
    if (P->tok.kind != TOK_LBRACE)
        return fail(P, P->tok.loc, "%s: expected '{', found %s", what, tok_desc(&P->tok, buf, sizeof buf));
    Loc open = P->tok.loc;
    if (next(P))
        return -1;
    while (P->tok.kind != TOK_RBRACE) {
        if (P->tok.kind == TOK_EOF)
            return fail(P, P->tok.loc, "%s: missing '}' before end of file (to close the '{' at %d:%d)", what,
                        open.line, open.col);
        if (P->tok.kind != TOK_IDENT)
            return fail(P, P->tok.loc, "%s: expected a property name, found %s", what,
                        tok_desc(&P->tok, buf, sizeof buf));
        int i = find_field(f, nf, &P->tok);
        if (i < 0 && is_keyword(&P->tok) && opens_block(P))
            return fail(P, P->tok.loc, "%s: missing '}' before '%.*s' (to close the '{' at %d:%d)", what,
                        (int)P->tok.len, P->tok.start, open.line, open.col);
        if (i < 0)
            return fail(P, P->tok.loc, "%s: unknown property '%.*s'", what, (int)P->tok.len, P->tok.start);
        Value *v = &vals[i];
        if (v->set)
            return fail(P, P->tok.loc, "%s: duplicate property '%s' (first given at %d:%d)", what, f[i].key,
                        v->key.line, v->key.col);
        v->set = 1;
        v->key = P->tok.loc;
        if (next(P))
            return -1;
        v->value = P->tok.loc;
        FieldKind kind = f[i].kind;
        int count = kind == F_VEC ? 3 : kind == F_PAIR ? 2 : kind == F_MAT ? 12 : 0;
        if (kind == F_NUM || kind == F_SCALE)
            count = 1;
        if (kind == F_STRING) {
            if (P->tok.kind == TOK_RBRACE || P->tok.kind == TOK_EOF)
                return fail(P, P->tok.loc, "%s: missing value for '%s' (expects a quoted string)", what, f[i].key);
            if (P->tok.kind != TOK_STRING)
                return fail(P, P->tok.loc, "%s: wrong type for '%s': expected a quoted string, found %s", what,
                            f[i].key, tok_desc(&P->tok, buf, sizeof buf));
            size_t o = 0;
            for (size_t k = 1; k + 1 < P->tok.len; k++) {
                if (P->tok.start[k] == '\\' && (P->tok.start[k + 1] == '"' || P->tok.start[k + 1] == '\\'))
                    k++; /* \" and \\ escape; any other backslash is itself */
                if (o + 1 >= sizeof v->str)
                    return fail(P, P->tok.loc, "%s: '%s' is longer than %d characters", what, f[i].key,
                                SCENE_PATH_MAX - 1);
                v->str[o++] = P->tok.start[k];
            }
            v->str[o] = '\0';
            if (next(P))
                return -1;
        }
        if (kind == F_NAME) {
            if (P->tok.kind == TOK_RBRACE || P->tok.kind == TOK_EOF ||
                (P->tok.kind == TOK_IDENT && find_field(f, nf, &P->tok) >= 0 && value_follows(P)))
                return fail(P, P->tok.loc, "%s: missing value for '%s' (expects a name)", what, f[i].key);
            if (P->tok.kind != TOK_IDENT)
                return fail(P, P->tok.loc, "%s: wrong type for '%s': expected a name, found %s", what, f[i].key,
                            tok_desc(&P->tok, buf, sizeof buf));
            if (read_name(P, v->name, what))
                return -1;
        }
        for (int k = 0; k < count; k++) {
            if (P->tok.kind == TOK_NUMBER) {
                v->v[k] = P->tok.num;
                v->n = k + 1;
                if (next(P))
                    return -1;
                if (kind == F_SCALE && k == 0 && P->tok.kind == TOK_NUMBER)
                    count = 3; /* a second number: three of them */
                continue;
            }
            /* A '}' or another property where a value belongs means the value
             * was left out; anything else is a value of the wrong type. */
            if (P->tok.kind == TOK_RBRACE || P->tok.kind == TOK_EOF || find_field(f, nf, &P->tok) >= 0) {
                if (count == 1)
                    return fail(P, P->tok.loc, "%s: missing value for '%s' (expects a number)", what, f[i].key);
                return fail(P, P->tok.loc, "%s: missing value for '%s' (expects %s, got %d)", what, f[i].key,
                            kind_desc(kind), k);
            }
            return fail(P, P->tok.loc, "%s: wrong type for '%s': expected a number, found %s", what, f[i].key,
                        tok_desc(&P->tok, buf, sizeof buf));
        }
        if (P->tok.kind == TOK_NUMBER)
            return fail(P, P->tok.loc, "%s: extra value '%.*s' after '%s' (expects %s)", what, (int)P->tok.len,
                        P->tok.start, f[i].key, kind_desc(kind));
    }
    return next(P);
}

static int require(Parser *P, const char *what, const Field *f, const Value *vals, int i, Loc block)
{
    if (!vals[i].set)
        return fail(P, block, "%s: missing property '%s'", what, f[i].key);
    return 0;
}

static Vec3 vec_of(const Value *v) { return vec3((float)v->v[0], (float)v->v[1], (float)v->v[2]); }

static Vec3 vec_or(const Value *v, Vec3 dflt) { return v->set ? vec_of(v) : dflt; }

static float num_or(const Value *v, float dflt) { return v->set ? (float)v->v[0] : dflt; }

static void dvec_of(const Value *v, double out[3]) { memcpy(out, v->v, sizeof(double) * 3); }

static Vec3 round3(const double v[3]) { return vec3((float)v[0], (float)v[1], (float)v[2]); }

/* ---- growing the scene's arrays (bounded by the file size) ---- */

static void *grow(void *arr, int *cap, int count, size_t elem)
{
    if (count < *cap)
        return arr;
    int ncap = *cap ? *cap * 2 : 8;
    void *p = big_realloc(arr, (size_t)count * elem, (size_t)ncap * elem);
    if (p)
        *cap = ncap;
    return p;
}

/* A new primitive, and its Place (zeroed) in *pl. */
static Prim *new_prim(Parser *P, PrimKind kind, Loc loc, Place **pl)
{
    Prim *arr = grow(P->s->prims, &P->cap_prims, P->s->nprims, sizeof(Prim));
    if (arr)
        P->s->prims = arr;
    Place *parr = arr ? grow(P->s->place, &P->cap_place, P->s->nprims, sizeof(Place)) : NULL;
    if (!parr) {
        fail(P, loc, "out of memory");
        return NULL;
    }
    P->s->place = parr;
    *pl = &parr[P->s->nprims];
    memset(*pl, 0, sizeof **pl);
    Prim *p = &arr[P->s->nprims++];
    memset(p, 0, sizeof *p);
    p->kind = kind;
    return p;
}

/* The slot of P->names where name is, or the free one where it would go:
 * without the table, a scene's materials took time in their count squared. */
static int name_slot(const Parser *P, const char *name)
{
    const int mask = P->cap_names - 1;
    int j = (int)(lex_hash_str(name, P->name_seed) & (uint64_t)mask);
    while (P->names[j] >= 0 && strcmp(P->s->materials[P->names[j]].name, name) != 0)
        j = (j + 1) & mask;
    return j;
}

static int find_material(const Parser *P, const char *name)
{
    return P->cap_names ? P->names[name_slot(P, name)] : -1;
}

/* Enters material i, the last added, into P->names, twice as large as the
 * materials at least. Returns 0, or -1 when out of memory. */
static int name_material(Parser *P, int i)
{
    if (2 * (size_t)(i + 1) > (size_t)P->cap_names) {
        const int cap = P->cap_names ? 2 * P->cap_names : 64;
        int *t = malloc(sizeof *t * (size_t)cap);
        if (!t)
            return -1;
        free(P->names);
        P->names = t;
        P->cap_names = cap;
        for (int j = 0; j < cap; j++)
            t[j] = -1;
        for (int k = 0; k < i; k++)
            t[name_slot(P, P->s->materials[k].name)] = k;
    }
    P->names[name_slot(P, P->s->materials[i].name)] = i;
    return 0;
}

/* Resolves a required 'material NAME' property. */
static int material_ref(Parser *P, const char *what, const Field *f, const Value *vals, int i, Loc block,
                        int *out)
{
    if (require(P, what, f, vals, i, block))
        return -1;
    *out = find_material(P, vals[i].name);
    if (*out < 0)
        return fail(P, vals[i].value, "%s: undefined material '%s'", what, vals[i].name);
    return 0;
}

static int nonzero_vec(Parser *P, const char *what, const char *key, const Value *v)
{
    float len = vec_length(vec_of(v));
    if (len > 0.0f && isfinite(len))
        return 0;
    if (v->v[0] == 0.0f && v->v[1] == 0.0f && v->v[2] == 0.0f)
        return fail(P, v->value, "%s: '%s' must have non-zero length", what, key);
    return fail(P, v->value, "%s: '%s' is too small or too large to normalize", what, key);
}

/* ---- statements ---- */

/* A whole number in [lo, hi]. */
static int whole(const Value *v, int k, double lo, double hi)
{
    double x = v->v[k];
    return x == floor(x) && x >= lo && x <= hi;
}

/* An optional 'pn_mode exact|fast' into *mode, or -1 when it is not set. */
static int pn_mode_of(Parser *P, const char *what, const Value *v, int *mode)
{
    *mode = -1;
    if (!v->set)
        return 0;
    *mode = pn_mode_named(v->name);
    if (*mode < 0)
        return fail(P, v->value, "%s: 'pn_mode' must be 'exact' or 'fast', not '%s'", what, v->name);
    return 0;
}

static int parse_image(Parser *P, Loc at)
{
    enum { WIDTH, HEIGHT, BACKGROUND, MAX_DEPTH, SPP, INTERSECT, PN_MODE, ADC_BAILOUT, AA_THRESHOLD, N };
    static const Field f[N] = {{"width", F_NUM},       {"height", F_NUM},      {"background", F_VEC},
                               {"max_depth", F_NUM},   {"spp", F_NUM},         {"intersect", F_NAME},
                               {"pn_mode", F_NAME},    {"adc_bailout", F_NUM}, {"aa_threshold", F_NUM}};
    Value v[N];
    if (P->have_image)
        return fail(P, at, "duplicate 'image' block");
    P->have_image = 1;
    if (parse_block(P, "image", f, N, v))
        return -1;
    for (int i = WIDTH; i <= HEIGHT; i++) {
        if (v[i].set && !whole(&v[i], 0, 1, LIMIT_IMAGE_SIDE))
            return fail(P, v[i].value, "image: '%s' must be a whole number from 1 to %d", f[i].key, LIMIT_IMAGE_SIDE);
    }
    if (v[MAX_DEPTH].set && !whole(&v[MAX_DEPTH], 0, 1, LIMIT_DEPTH))
        return fail(P, v[MAX_DEPTH].value, "image: 'max_depth' must be a whole number from 1 to %d", LIMIT_DEPTH);
    if (v[SPP].set && !whole(&v[SPP], 0, 1, LIMIT_SPP))
        return fail(P, v[SPP].value, "image: 'spp' must be a whole number from 1 to %d", LIMIT_SPP);
    P->s->image.spp = (int)num_or(&v[SPP], (float)P->s->image.spp);
    if (v[ADC_BAILOUT].set && !(v[ADC_BAILOUT].v[0] >= 0.0 && (float)v[ADC_BAILOUT].v[0] < 1.0f))
        return fail(P, v[ADC_BAILOUT].value, "image: 'adc_bailout' must be a number from 0 up to 1, 1 excluded%s",
                    v[ADC_BAILOUT].v[0] >= 0.0 && v[ADC_BAILOUT].v[0] < 1.0 ? " (it rounds to 1 as a float)" : "");
    P->s->image.adc_bailout = num_or(&v[ADC_BAILOUT], P->s->image.adc_bailout);
    /* (in float too: a threshold that rounds to 0 would turn the adaptive
     * anti-aliasing off, which 0 means) */
    if (v[AA_THRESHOLD].set && !((float)v[AA_THRESHOLD].v[0] > 0.0f && v[AA_THRESHOLD].v[0] <= 3.0))
        return fail(P, v[AA_THRESHOLD].value, "image: 'aa_threshold' must be a number above 0, at most 3%s",
                    v[AA_THRESHOLD].v[0] > 0.0 && v[AA_THRESHOLD].v[0] <= 3.0 ? " (it rounds to 0 as a float)" : "");
    P->s->image.aa_threshold = num_or(&v[AA_THRESHOLD], 0.0f);
    if (v[INTERSECT].set) {
        if (strcmp(v[INTERSECT].name, "classic") != 0 && strcmp(v[INTERSECT].name, "robust") != 0)
            return fail(P, v[INTERSECT].value, "image: 'intersect' must be 'robust' or 'classic', not '%s'",
                        v[INTERSECT].name);
        P->s->image.classic = strcmp(v[INTERSECT].name, "classic") == 0;
    }
    int mode;
    if (pn_mode_of(P, "image", &v[PN_MODE], &mode))
        return -1;
    if (mode >= 0)
        P->s->image.pn_mode = mode;
    SceneImage *im = &P->s->image;
    im->width = (int)num_or(&v[WIDTH], (float)im->width);
    im->height = (int)num_or(&v[HEIGHT], (float)im->height);
    im->max_depth = (int)num_or(&v[MAX_DEPTH], (float)im->max_depth);
    P->s->background = vec_or(&v[BACKGROUND], P->s->background);
    if ((long)im->width * im->height > LIMIT_IMAGE_PIXELS)
        return fail(P, at, "image: %d x %d is more than the %ld pixels lancer renders", im->width, im->height,
                    LIMIT_IMAGE_PIXELS);
    return 0;
}

static int parse_camera(Parser *P, Loc at)
{
    enum { EYE, TARGET, UP, FOV, N };
    static const Field f[N] = {{"eye", F_VEC}, {"target", F_VEC}, {"up", F_VEC}, {"fov", F_NUM}};
    Value v[N];
    if (P->have_camera)
        return fail(P, at, "duplicate 'camera' block");
    P->have_camera = 1;
    if (parse_block(P, "camera", f, N, v))
        return -1;
    for (int i = 0; i < N; i++)
        if (i != UP && require(P, "camera", f, v, i, at))
            return -1;
    CameraSpec *c = &P->s->camera;
    dvec_of(&v[EYE], c->eye_at);
    dvec_of(&v[TARGET], c->target_at);
    c->eye = round3(c->eye_at);
    c->target = round3(c->target_at);
    c->up = vec_or(&v[UP], vec3(0, 1, 0));
    c->fovy = (float)v[FOV].v[0];
    /* the view direction in double: an eye and target far out may round to
     * one float, and still be apart next to the camera */
    const double *e = c->eye_at, *t = c->target_at;
    Vec3 fwd = vec3((float)(t[0] - e[0]), (float)(t[1] - e[1]), (float)(t[2] - e[2]));
    if (t[0] == e[0] && t[1] == e[1] && t[2] == e[2])
        return fail(P, v[TARGET].value, "camera: 'target' must differ from 'eye'");
    if (!(vec_length(fwd) > 0.0f && isfinite(vec_length(fwd))))
        return fail(P, v[TARGET].value, "camera: 'target' is too close to or too far from 'eye'");
    if (v[UP].set && nonzero_vec(P, "camera", "up", &v[UP]))
        return -1;
    if (!(vec_length(vec_cross(vec_normalize(fwd), vec_normalize(c->up))) > 1e-6f))
        return fail(P, v[UP].set ? v[UP].value : at, "camera: 'up'%s must not be parallel to the view direction",
                    v[UP].set ? "" : " (by default 0 1 0)");
    if (!(c->fovy > 0.0f && c->fovy < 180.0f)) {
        if (v[FOV].v[0] > 0.0 && v[FOV].v[0] < 180.0) /* in range, but not as a float */
            return fail(P, v[FOV].value, "camera: 'fov' must be between 0 and 180 degrees (it is %g in single precision)",
                        (double)c->fovy);
        return fail(P, v[FOV].value, "camera: 'fov' must be between 0 and 180 degrees");
    }
    return 0;
}

/* A key of the camera path. Keys come in the order of their frames; fov,
 * when not given, is the camera block's. */
static int parse_keyframe(Parser *P, Loc at)
{
    enum { FRAME, EYE, TARGET, FOV, N };
    static const Field f[N] = {{"frame", F_NUM}, {"eye", F_VEC}, {"target", F_VEC}, {"fov", F_NUM}};
    Value v[N];
    Scene *s = P->s;
    if (parse_block(P, "keyframe", f, N, v))
        return -1;
    for (int i = 0; i < FOV; i++)
        if (require(P, "keyframe", f, v, i, at))
            return -1;
    if (!whole(&v[FRAME], 0, 0, LIMIT_FRAME))
        return fail(P, v[FRAME].value, "keyframe: 'frame' must be a whole number from 0 to %d", LIMIT_FRAME);
    int frame = (int)v[FRAME].v[0];
    if (s->nkeys > 0 && frame <= s->keys[s->nkeys - 1].frame)
        return fail(P, v[FRAME].value, "keyframe: frame %d must come after frame %d (keys go in the order of their frames)",
                    frame, s->keys[s->nkeys - 1].frame);
    if (v[EYE].v[0] == v[TARGET].v[0] && v[EYE].v[1] == v[TARGET].v[1] && v[EYE].v[2] == v[TARGET].v[2])
        return fail(P, v[TARGET].value, "keyframe: 'target' must differ from 'eye'");
    if (v[FOV].set && !((float)v[FOV].v[0] > 0.0f && (float)v[FOV].v[0] < 180.0f)) /* as the camera's */
        return fail(P, v[FOV].value, "keyframe: 'fov' must be between 0 and 180 degrees%s",
                    v[FOV].v[0] > 0.0 && v[FOV].v[0] < 180.0 ? " (not in single precision)" : "");
    if (s->nkeys == P->cap_keys) {
        int cap = P->cap_keys ? 2 * P->cap_keys : 8;
        CameraKey *k = realloc(s->keys, sizeof *k * (size_t)cap);
        if (!k)
            return fail(P, at, "out of memory");
        s->keys = k;
        P->cap_keys = cap;
    }
    CameraKey *k = &s->keys[s->nkeys++];
    k->frame = frame;
    dvec_of(&v[EYE], k->eye);
    dvec_of(&v[TARGET], k->target);
    k->fov = v[FOV].set ? v[FOV].v[0] : -1.0; /* the camera block's, at the end */
    return 0;
}

/* Component c of the keys' values (val) at frame f, f0 <= f < f1 of keys
 * i and i+1: a cubic Hermite segment whose tangents are Catmull-Rom's over
 * non-uniform knots, (p[i+1] - p[i-1]) / (f[i+1] - f[i-1]), one-sided at
 * the path's ends. On a key it is the key's value exactly. */
static double path_at(const CameraKey *k, int n, int i, double f, double (*val)(const CameraKey *, int), int c)
{
    double f0 = k[i].frame, f1 = k[i + 1].frame, h = f1 - f0, s = (f - f0) / h;
    double p0 = val(&k[i], c), p1 = val(&k[i + 1], c);
    double m0 = i > 0 ? (p1 - val(&k[i - 1], c)) / (f1 - k[i - 1].frame) : (p1 - p0) / h;
    double m1 = i + 2 < n ? (val(&k[i + 2], c) - p0) / (k[i + 2].frame - f0) : (p1 - p0) / h;
    double s2 = s * s, s3 = s2 * s;
    return (2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * h * m0 + (3 * s2 - 2 * s3) * p1 + (s3 - s2) * h * m1;
}

static double key_eye(const CameraKey *k, int c) { return k->eye[c]; }
static double key_target(const CameraKey *k, int c) { return k->target[c]; }
static double key_fov(const CameraKey *k, int c) { return (void)c, k->fov; }

int scene_camera_frame(Scene *s, int frame, char *err, size_t errlen)
{
    if (s->nkeys == 0) {
        snprintf(err, errlen, "the scene has no camera path (no 'keyframe' block)");
        return -1;
    }
    const CameraKey *k = s->keys;
    int n = s->nkeys, i = 0;
    CameraSpec *c = &s->camera;
    double fov;
    if (frame <= k[0].frame || frame >= k[n - 1].frame) {
        const CameraKey *e = frame <= k[0].frame ? &k[0] : &k[n - 1];
        memcpy(c->eye_at, e->eye, sizeof c->eye_at);
        memcpy(c->target_at, e->target, sizeof c->target_at);
        fov = e->fov;
    } else {
        while (k[i + 1].frame <= frame)
            i++;
        for (int d = 0; d < 3; d++) {
            c->eye_at[d] = path_at(k, n, i, frame, key_eye, d);
            c->target_at[d] = path_at(k, n, i, frame, key_target, d);
        }
        fov = path_at(k, n, i, frame, key_fov, 0);
    }
    c->eye = round3(c->eye_at);
    c->target = round3(c->target_at);
    c->fovy = (float)fov;
    const double *e = c->eye_at, *t = c->target_at;
    Vec3 fwd = vec3((float)(t[0] - e[0]), (float)(t[1] - e[1]), (float)(t[2] - e[2]));
    const char *bad = NULL;
    if (!vec_is_finite(c->eye) || !vec_is_finite(c->target))
        bad = "puts the camera out of float's range";
    else if (!(vec_length(fwd) > 0.0f && isfinite(vec_length(fwd))))
        bad = "puts the eye on the target";
    else if (!(vec_length(vec_cross(vec_normalize(fwd), vec_normalize(c->up))) > 1e-6f))
        bad = "turns the view along the camera's up";
    else if (!(c->fovy > 0.0f && c->fovy < 180.0f))
        bad = "takes fov out of 0 to 180 degrees";
    if (bad) {
        snprintf(err, errlen, "frame %d: the camera path %s", frame, bad);
        return -1;
    }
    return 0;
}

static int parse_light(Parser *P, Loc at)
{
    enum { POSITION, COLOR, FADE_DISTANCE, FADE_POWER, SHADOWLESS, AREA_U, AREA_V, AREA_SAMPLES, AREA_ADAPTIVE, N };
    static const Field f[N] = {{"position", F_VEC},   {"color", F_VEC},   {"fade_distance", F_NUM},
                               {"fade_power", F_NUM}, {"shadowless", F_FLAG}, {"area_u", F_VEC},
                               {"area_v", F_VEC},     {"area_samples", F_PAIR}, {"area_adaptive", F_NUM}};
    Value v[N];
    if (parse_block(P, "light", f, N, v) || require(P, "light", f, v, POSITION, at))
        return -1;
    Light l;
    dvec_of(&v[POSITION], l.at);
    l.pos = vec_of(&v[POSITION]);
    l.color = vec_or(&v[COLOR], vec3(1, 1, 1));
    l.fade_distance = num_or(&v[FADE_DISTANCE], 0.0f);
    l.fade_power = num_or(&v[FADE_POWER], 0.0f);
    l.shadowless = v[SHADOWLESS].set;
    if (v[FADE_DISTANCE].set && !(l.fade_distance > 0.0f))
        return fail(P, v[FADE_DISTANCE].value, "light: 'fade_distance' must be positive");
    if (l.fade_power < 0.0f)
        return fail(P, v[FADE_POWER].value, "light: 'fade_power' must not be negative");
    if (l.fade_power > 0.0f && !v[FADE_DISTANCE].set)
        return fail(P, v[FADE_POWER].key, "light: 'fade_power' needs 'fade_distance'");
    /* An area light needs all three of its properties, as in POV-Ray. */
    int area = v[AREA_U].set + v[AREA_V].set + v[AREA_SAMPLES].set;
    if (area > 0 && area < 3)
        return fail(P, at, "light: an area light needs 'area_u', 'area_v' and 'area_samples'");
    l.area_u = vec_or(&v[AREA_U], vec3(0, 0, 0));
    l.area_v = vec_or(&v[AREA_V], vec3(0, 0, 0));
    l.area_n1 = l.area_n2 = 1;
    l.adaptive = 0;
    if (v[AREA_ADAPTIVE].set && !area)
        return fail(P, v[AREA_ADAPTIVE].key, "light: 'area_adaptive' is for an area light");
    if (v[AREA_ADAPTIVE].set && !whole(&v[AREA_ADAPTIVE], 0, 0, LIMIT_AREA_ADAPTIVE))
        return fail(P, v[AREA_ADAPTIVE].value, "light: 'area_adaptive' must be a whole number from 0 to %d",
                    LIMIT_AREA_ADAPTIVE);
    if (v[AREA_ADAPTIVE].set)
        l.adaptive = 1 + (int)v[AREA_ADAPTIVE].v[0];
    if (area) {
        if (!whole(&v[AREA_SAMPLES], 0, 1, LIMIT_AREA_SAMPLES) ||
            !whole(&v[AREA_SAMPLES], 1, 1, LIMIT_AREA_SAMPLES))
            return fail(P, v[AREA_SAMPLES].value, "light: 'area_samples' must be two whole numbers from 1 to %d",
                        LIMIT_AREA_SAMPLES);
        l.area_n1 = (int)v[AREA_SAMPLES].v[0];
        l.area_n2 = (int)v[AREA_SAMPLES].v[1];
    }
    P->light_samples += l.area_n1 * l.area_n2;
    if (P->light_samples > LIMIT_LIGHT_SAMPLES)
        return fail(P, area ? v[AREA_SAMPLES].value : at,
                    "light: the scene's lights would take %lld samples, more than %d in all", P->light_samples,
                    LIMIT_LIGHT_SAMPLES);
    Light *arr = grow(P->s->lights, &P->cap_lights, P->s->nlights, sizeof(Light));
    if (!arr)
        return fail(P, at, "out of memory");
    P->s->lights = arr;
    arr[P->s->nlights++] = l;
    return 0;
}

static int parse_material(Parser *P, Loc at)
{
    enum { COLOR, AMBIENT, DIFFUSE, PHONG, PHONG_SIZE, SPECULAR, ROUGHNESS, REFLECTION, FILTER, TRANSMIT, IOR, N };
    static const Field f[N] = {{"color", F_VEC},      {"ambient", F_NUM},    {"diffuse", F_NUM},
                               {"phong", F_NUM},      {"phong_size", F_NUM}, {"specular", F_NUM},
                               {"roughness", F_NUM},  {"reflection", F_NUM}, {"filter", F_NUM},
                               {"transmit", F_NUM},   {"ior", F_NUM}};
    Value v[N];
    Material m;
    Loc name_at = P->tok.loc;
    if (read_name(P, m.name, "material"))
        return -1;
    int prev = find_material(P, m.name);
    if (prev >= 0)
        return fail(P, name_at, "duplicate material name '%s'", m.name);
    if (parse_block(P, "material", f, N, v))
        return -1;
    /* Defaults are POV-Ray 3.7's, so an unset value means the same there. */
    m.color = vec_or(&v[COLOR], vec3(1, 1, 1));
    m.ambient = num_or(&v[AMBIENT], 0.1f);
    m.diffuse = num_or(&v[DIFFUSE], 0.6f);
    m.phong = num_or(&v[PHONG], 0.0f);
    m.phong_size = num_or(&v[PHONG_SIZE], 40.0f);
    m.specular = num_or(&v[SPECULAR], 0.0f);
    m.roughness = num_or(&v[ROUGHNESS], 0.05f);
    m.reflection = num_or(&v[REFLECTION], 0.0f);
    m.filter = num_or(&v[FILTER], 0.0f);
    m.transmit = num_or(&v[TRANSMIT], 0.0f);
    m.ior = num_or(&v[IOR], 1.0f);
    for (int i = AMBIENT; i < N; i++)
        if (v[i].v[0] < 0.0f)
            return fail(P, v[i].value, "material: '%s' must not be negative", f[i].key);
    if (v[COLOR].set && (m.color.x < 0.0f || m.color.y < 0.0f || m.color.z < 0.0f))
        return fail(P, v[COLOR].value, "material: 'color' must not be negative");
    if (v[ROUGHNESS].set && !(m.roughness > 0.0f))
        return fail(P, v[ROUGHNESS].value, "material: 'roughness' must be positive");
    if (m.filter + m.transmit > 1.0f)
        return fail(P, v[v[TRANSMIT].set ? TRANSMIT : FILTER].value,
                    "material: 'filter' and 'transmit' must add up to at most 1");
    if (v[IOR].set && !(m.ior > 0.0f))
        return fail(P, v[IOR].value, "material: 'ior' must be positive");
    Material *arr = grow(P->s->materials, &P->cap_materials, P->s->nmaterials, sizeof(Material));
    if (!arr)
        return fail(P, at, "out of memory");
    P->s->materials = arr;
    arr[P->s->nmaterials++] = m;
    if (name_material(P, P->s->nmaterials - 1) != 0)
        return fail(P, at, "out of memory");
    return 0;
}

/* ---- transforms: 3x4 affine maps in double, rows of M then t ---- */

static const double XF_IDENTITY[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};

/* c = a after b. */
static void xf_compose(const double a[12], const double b[12], double c[12])
{
    double m[12];
    for (int r = 0; r < 3; r++) {
        for (int k = 0; k < 3; k++)
            m[3 * r + k] = a[3 * r] * b[k] + a[3 * r + 1] * b[3 + k] + a[3 * r + 2] * b[6 + k];
        m[9 + r] = a[3 * r] * b[9] + a[3 * r + 1] * b[10] + a[3 * r + 2] * b[11] + a[9 + r];
    }
    memcpy(c, m, sizeof m);
}

/* Rotation by deg degrees about axis 0, 1 or 2 (right-handed). Quarter
 * turns are exact: a box turned by 90 degrees stays a box. */
static void xf_rotation(int axis, double deg, double r[12])
{
    double c, sn, q = deg / 90.0;
    if (q == floor(q)) {
        static const double cs[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
        int k = (int)fmod(fmod(q, 4.0) + 4.0, 4.0);
        c = cs[k][0], sn = cs[k][1];
    } else {
        double rad = deg * 3.14159265358979323846 / 180.0;
        c = cos(rad), sn = sin(rad);
    }
    memcpy(r, XF_IDENTITY, sizeof(double) * 12);
    int i = (axis + 1) % 3, j = (axis + 2) % 3;
    r[3 * i + i] = c;
    r[3 * i + j] = -sn;
    r[3 * j + i] = sn;
    r[3 * j + j] = c;
}

/* The cofactor matrix of M (rows: the cross products of M's rows), which
 * is det(M) times M^-T, and det(M). */
static double xf_cofactors(const double *xf, double c[9])
{
    for (int r = 0; r < 3; r++)
        d3_cross(c + 3 * r, xf + 3 * ((r + 1) % 3), xf + 3 * ((r + 2) % 3));
    return d3_dot(xf, c);
}

static int xf_regular(const double *xf)
{
    double c[9], det = xf_cofactors(xf, c);
    for (int k = 0; k < 12; k++)
        if (!isfinite(xf[k]))
            return 0;
    return fabs(det) > 0.0 && isfinite(det);
}

/* M p + t (xf NULL: p). */
static void xf_point(const double *xf, const double p[3], double out[3])
{
    double q[3];
    for (int r = 0; r < 3; r++)
        q[r] = xf ? xf[3 * r] * p[0] + xf[3 * r + 1] * p[1] + xf[3 * r + 2] * p[2] + xf[9 + r] : p[r];
    memcpy(out, q, sizeof q);
}

/* M v: a direction. */
static void xf_dir(const double *xf, const double v[3], double out[3])
{
    double q[3];
    for (int r = 0; r < 3; r++)
        q[r] = xf[3 * r] * v[0] + xf[3 * r + 1] * v[1] + xf[3 * r + 2] * v[2];
    memcpy(out, q, sizeof q);
}

/* A normal, through the inverse transpose: the cofactor matrix, with the
 * determinant's sign (its size is lost on normalising); unit length. */
static void xf_normal(const double *xf, const double n[3], double out[3])
{
    double c[9], q[3];
    if (!xf) {
        memcpy(q, n, sizeof q);
    } else {
        double det = xf_cofactors(xf, c);
        for (int r = 0; r < 3; r++)
            q[r] = (c[3 * r] * n[0] + c[3 * r + 1] * n[1] + c[3 * r + 2] * n[2]) * (det < 0.0 ? -1.0 : 1.0);
    }
    double len = sqrt(d3_dot(q, q));
    for (int r = 0; r < 3; r++)
        out[r] = q[r] / len;
}

/* 1 when M is a rotation times a uniform scale s (> 0), to within what its
 * double rounding leaves (a relative 1e-12, far below a float's spacing):
 * M M^T = s^2 I. */
static int xf_similarity(const double *xf, double *s)
{
    double g[9], s2 = 0.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            g[3 * i + j] = xf[3 * i] * xf[3 * j] + xf[3 * i + 1] * xf[3 * j + 1] + xf[3 * i + 2] * xf[3 * j + 2];
    s2 = (g[0] + g[4] + g[8]) / 3.0;
    for (int k = 0; k < 9; k++)
        if (!(fabs(g[k] - (k % 4 == 0 ? s2 : 0.0)) <= 1e-12 * s2))
            return 0;
    *s = sqrt(s2);
    return 1;
}

/* 1 when M maps each axis onto an axis (a diagonal matrix, or one whose
 * rows are permuted: quarter turns): it maps an axis-aligned box to one. */
static int xf_axis_aligned(const double *xf)
{
    for (int r = 0; r < 3; r++)
        if ((xf[3 * r] != 0.0) + (xf[3 * r + 1] != 0.0) + (xf[3 * r + 2] != 0.0) != 1)
            return 0;
    return 1; /* one non-zero per row, and M is regular: one per column too */
}

/* The transform of an object's keys (v: its XF_N values): matrix first,
 * then scale, rotate (about x, then y, then z) and translate, as the
 * README lists them. A singular or non-finite one is an error at its key.
 * *any: whether a key was given. */
static int parse_xf(Parser *P, const char *what, const Value *v, Loc at, double xf[12], int *any)
{
    memcpy(xf, XF_IDENTITY, sizeof(double) * 12);
    *any = v[XF_MATRIX].set || v[XF_SCALE].set || v[XF_ROTATE].set || v[XF_TRANSLATE].set;
    if (v[XF_MATRIX].set) {
        memcpy(xf, v[XF_MATRIX].v, sizeof(double) * 12);
        if (!xf_regular(xf))
            return fail(P, v[XF_MATRIX].value, "%s: 'matrix' is singular: its 3x3 part has no inverse", what);
    }
    if (v[XF_SCALE].set) {
        const Value *sc = &v[XF_SCALE];
        double sx = sc->v[0], sy = sc->n == 3 ? sc->v[1] : sx, sz = sc->n == 3 ? sc->v[2] : sx;
        if (sx == 0.0 || sy == 0.0 || sz == 0.0)
            return fail(P, sc->value, "%s: 'scale' must not be zero", what);
        const double m[12] = {sx, 0, 0, 0, sy, 0, 0, 0, sz, 0, 0, 0};
        xf_compose(m, xf, xf);
    }
    for (int axis = 0; v[XF_ROTATE].set && axis < 3; axis++) {
        double r[12];
        xf_rotation(axis, v[XF_ROTATE].v[axis], r);
        xf_compose(r, xf, xf);
    }
    if (v[XF_TRANSLATE].set)
        for (int k = 0; k < 3; k++)
            xf[9 + k] += v[XF_TRANSLATE].v[k];
    if (!xf_regular(xf))
        return fail(P, at, "%s: the transform is singular or not finite", what);
    return 0;
}

/* ---- objects ---- */

/* Not collinear (and no NaN): the triangle has a normal. */
static int tri_has_area(Vec3 a, Vec3 b, Vec3 c) { return vec_length(vec_cross(vec_sub(b, a), vec_sub(c, a))) > 0.0f; }

/* The same in double. */
static int tri_has_area_d(const double a[3], const double b[3], const double c[3])
{
    double u[3], w[3], n[3];
    for (int k = 0; k < 3; k++)
        u[k] = b[k] - a[k], w[k] = c[k] - a[k];
    d3_cross(n, u, w);
    return d3_dot(n, n) > 0.0;
}

/* Sets primitive i's float coordinates from its Place (Scene.place): each
 * rounded once. Returns 0, or -1 when an oriented box's axes turn
 * dependent. */
static int derive(Scene *s, int i)
{
    Prim *p = &s->prims[i];
    const Place *q = &s->place[i];
    switch (p->kind) {
    case PRIM_SPHERE:
        p->g.sphere.c = round3(q->p[0]);
        p->g.sphere.r = (float)q->p[1][0];
        break;
    case PRIM_PLANE:
        p->g.plane.n = round3(q->p[0]);
        p->g.plane.d = (float)q->p[1][0];
        break;
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE:
        p->g.tri.a = round3(q->p[0]);
        p->g.tri.b = round3(q->p[1]);
        p->g.tri.c = round3(q->p[2]);
        break;
    case PRIM_BOX:
        p->g.box.lo = round3(q->p[0]);
        p->g.box.hi = round3(q->p[1]);
        break;
    case PRIM_OBOX:
        p->g.obox.c = round3(q->p[0]);
        return prim_obox_init(&p->g.obox);
    case PRIM_PN: { /* the net again, from the rounded vertices: neighbours round alike */
        PnPatch *pa = &s->patches[p->g.pn.index];
        const Vec3 v[3] = {round3(q->p[0]), round3(q->p[1]), round3(q->p[2])}, n[3] = {pa->n[0], pa->n[1], pa->n[2]};
        pn_patch_init(pa, v, n);
        break;
    }
    case PRIM_ELLIPSOID:
        break;
    }
    return 0;
}

/* Appends the patch of p and n (unit normals) to the scene's patches;
 * *cap is the array's room. Returns its index, or -1 when out of memory. */
static int add_patch(Scene *s, int *cap, const Vec3 p[3], const Vec3 n[3])
{
    PnPatch *arr = grow(s->patches, cap, s->npatches, sizeof(PnPatch));
    if (!arr)
        return -1;
    s->patches = arr;
    pn_patch_init(&arr[s->npatches], p, n);
    return s->npatches++;
}

/* The object's transform, or an error; xf NULL-able through *use. */
#define OBJECT_XF(what)                                                                                                \
    double xf_[12];                                                                                                    \
    int any_;                                                                                                          \
    if (parse_xf(P, what, &v[MATRIX], at, xf_, &any_))                                                                 \
        return -1;                                                                                                     \
    const double *xf = any_ ? xf_ : NULL

static int parse_sphere(Parser *P, Loc at)
{
    enum { CENTER, RADIUS, MATERIAL, MATRIX, N = MATRIX + XF_N };
    static const Field f[N] = {{"center", F_VEC}, {"radius", F_NUM}, {"material", F_NAME}, XF_FIELDS};
    Value v[N];
    int mat;
    if (parse_block(P, "sphere", f, N, v) || require(P, "sphere", f, v, CENTER, at) ||
        require(P, "sphere", f, v, RADIUS, at) || material_ref(P, "sphere", f, v, MATERIAL, at, &mat))
        return -1;
    if (!((float)v[RADIUS].v[0] > 0.0f)) /* and not below float's range */
        return fail(P, v[RADIUS].value, "sphere: 'radius' must be positive");
    OBJECT_XF("sphere");
    double c[3], r = v[RADIUS].v[0], k = 1.0;
    dvec_of(&v[CENTER], c);
    Place *pl;
    Prim *p;
    if (!xf || xf_similarity(xf, &k)) { /* a sphere again */
        if (!(p = new_prim(P, PRIM_SPHERE, at, &pl)))
            return -1;
        xf_point(xf, c, pl->p[0]);
        pl->p[1][0] = r * k;
    } else { /* an ellipsoid: the unit sphere, scaled by r, moved to c, then xf */
        Ellipsoid e;
        for (int i = 0; i < 9; i++)
            e.m[i] = xf[i] * r;
        xf_point(xf, c, e.m + 9);
        if (prim_ellipsoid_init(&e) != 0)
            return fail(P, at, "sphere: the transform is singular or not finite");
        Ellipsoid *arr = grow(P->s->ellipsoids, &P->cap_ellipsoids, P->s->nellipsoids, sizeof(Ellipsoid));
        if (!arr)
            return fail(P, at, "out of memory");
        P->s->ellipsoids = arr;
        arr[P->s->nellipsoids] = e;
        int(*line_col)[2] = grow(P->s->ellipsoid_at, &P->cap_ellipsoid_at, P->s->nellipsoids, sizeof *line_col);
        if (!line_col)
            return fail(P, at, "out of memory");
        P->s->ellipsoid_at = line_col;
        line_col[P->s->nellipsoids][0] = at.line;
        line_col[P->s->nellipsoids][1] = at.col;
        if (!(p = new_prim(P, PRIM_ELLIPSOID, at, &pl)))
            return -1;
        p->g.ell.index = P->s->nellipsoids++;
    }
    p->material = mat;
    derive(P->s, P->s->nprims - 1);
    return 0;
}

static int parse_plane(Parser *P, Loc at)
{
    enum { NORMAL, OFFSET, MATERIAL, MATRIX, N = MATRIX + XF_N };
    static const Field f[N] = {{"normal", F_VEC}, {"offset", F_NUM}, {"material", F_NAME}, XF_FIELDS};
    Value v[N];
    int mat;
    if (parse_block(P, "plane", f, N, v) || require(P, "plane", f, v, NORMAL, at) ||
        material_ref(P, "plane", f, v, MATERIAL, at, &mat) || nonzero_vec(P, "plane", "normal", &v[NORMAL]))
        return -1;
    OBJECT_XF("plane");
    double n[3], d = v[OFFSET].set ? v[OFFSET].v[0] : 0.0, q[3];
    dvec_of(&v[NORMAL], n);
    xf_normal(NULL, n, n);
    for (int k = 0; k < 3; k++)
        q[k] = n[k] * d; /* a point of the plane, which xf moves with it */
    Place *pl;
    Prim *p = new_prim(P, PRIM_PLANE, at, &pl);
    if (!p)
        return -1;
    p->material = mat;
    xf_normal(xf, n, pl->p[0]);
    xf_point(xf, q, q);
    pl->p[1][0] = pl->p[0][0] * q[0] + pl->p[0][1] * q[1] + pl->p[0][2] * q[2];
    derive(P->s, P->s->nprims - 1);
    return 0;
}

/* The three vertices of a triangle's keys (v[0..2]) and, with smooth,
 * its three normals (v[3..5]), through xf. Returns 0, or -1 when the
 * vertices are collinear. */
static int place_triangle(const Value *v, int smooth, const double *xf, double p[3][3], Vec3 n[3])
{
    for (int k = 0; k < 3; k++) {
        double q[3];
        dvec_of(&v[k], q);
        xf_point(xf, q, p[k]);
        if (smooth) {
            dvec_of(&v[3 + k], q);
            xf_normal(NULL, q, q); /* normalised before the transform, as a mesh's are */
            xf_normal(xf, q, q);
            n[k] = round3(q);
        }
    }
    return tri_has_area_d(p[0], p[1], p[2]) ? 0 : -1;
}

static int parse_triangle(Parser *P, Loc at, int smooth)
{
    enum { A, B, C, NA, NB, NC, MATERIAL, MATRIX, N = MATRIX + XF_N };
    static const Field f[N] = {{"a", F_VEC},  {"b", F_VEC},  {"c", F_VEC},        {"na", F_VEC},
                               {"nb", F_VEC}, {"nc", F_VEC}, {"material", F_NAME}, XF_FIELDS};
    const char *what = smooth ? "smooth_triangle" : "triangle";
    Value v[N];
    int mat;
    /* A flat triangle takes no normals: its table skips them. */
    static const Field flat[4 + XF_N] = {{"a", F_VEC}, {"b", F_VEC}, {"c", F_VEC}, {"material", F_NAME}, XF_FIELDS};
    if (smooth) {
        if (parse_block(P, what, f, N, v))
            return -1;
    } else {
        Value fv[4 + XF_N];
        if (parse_block(P, what, flat, 4 + XF_N, fv))
            return -1;
        memset(v, 0, sizeof v);
        v[A] = fv[0];
        v[B] = fv[1];
        v[C] = fv[2];
        v[MATERIAL] = fv[3];
        memcpy(&v[MATRIX], &fv[4], sizeof(Value) * XF_N);
    }
    for (int i = A; i <= (smooth ? NC : C); i++)
        if (require(P, what, f, v, i, at))
            return -1;
    if (material_ref(P, what, f, v, MATERIAL, at, &mat))
        return -1;
    if (smooth)
        for (int i = NA; i <= NC; i++)
            if (nonzero_vec(P, what, f[i].key, &v[i]))
                return -1;
    OBJECT_XF(what);
    double pt[3][3];
    Vec3 n[3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}; /* zero for a flat triangle */
    if (place_triangle(v, smooth, xf, pt, n) != 0)
        return fail(P, at, "%s: the three vertices are collinear (zero area)", what);
    Place *pl;
    Prim *p = new_prim(P, smooth ? PRIM_SMOOTH_TRIANGLE : PRIM_TRIANGLE, at, &pl);
    if (!p)
        return -1;
    p->material = mat;
    memcpy(pl->p, pt, sizeof pt);
    p->g.tri.na = n[0];
    p->g.tri.nb = n[1];
    p->g.tri.nc = n[2];
    derive(P->s, P->s->nprims - 1);
    return 0;
}

static int parse_pn_triangle(Parser *P, Loc at)
{
    enum { A, B, C, NA, NB, NC, MATERIAL, PN_MODE, MATRIX, N = MATRIX + XF_N };
    static const Field f[N] = {{"a", F_VEC},  {"b", F_VEC},  {"c", F_VEC},         {"na", F_VEC},
                               {"nb", F_VEC}, {"nc", F_VEC}, {"material", F_NAME}, {"pn_mode", F_NAME},
                               XF_FIELDS};
    const char *what = "pn_triangle";
    Value v[N];
    int mat, mode;
    if (parse_block(P, what, f, N, v))
        return -1;
    for (int i = A; i <= NC; i++)
        if (require(P, what, f, v, i, at))
            return -1;
    if (material_ref(P, what, f, v, MATERIAL, at, &mat) || pn_mode_of(P, what, &v[PN_MODE], &mode))
        return -1;
    for (int i = NA; i <= NC; i++)
        if (nonzero_vec(P, what, f[i].key, &v[i]))
            return -1;
    OBJECT_XF(what);
    double pt[3][3];
    Vec3 nrm[3];
    if (place_triangle(v, 1, xf, pt, nrm) != 0)
        return fail(P, at, "%s: the three vertices are collinear (zero area)", what);
    const Vec3 pts[3] = {round3(pt[0]), round3(pt[1]), round3(pt[2])};
    int idx = add_patch(P->s, &P->cap_patches, pts, nrm);
    Place *pl;
    Prim *p = idx < 0 ? NULL : new_prim(P, PRIM_PN, at, &pl);
    if (!p)
        return idx < 0 ? fail(P, at, "out of memory") : -1;
    p->material = mat;
    p->g.pn.index = idx;
    p->g.pn.mode = mode;
    memcpy(pl->p, pt, sizeof pt);
    return 0;
}

/* An oriented box of centre c and axes ax[3] (double) into a new
 * primitive. */
static int add_obox(Parser *P, const char *what, Loc at, int mat, const double c[3], double ax[3][3])
{
    Place *pl;
    Prim *p = new_prim(P, PRIM_OBOX, at, &pl);
    if (!p)
        return -1;
    p->material = mat;
    memcpy(pl->p[0], c, sizeof(double) * 3);
    p->g.obox.u = round3(ax[0]);
    p->g.obox.v = round3(ax[1]);
    p->g.obox.w = round3(ax[2]);
    if (derive(P->s, P->s->nprims - 1) != 0) {
        P->s->nprims--;
        return fail(P, at, "%s: axes 'u', 'v' and 'w' are linearly dependent (the box is flat) or too large", what);
    }
    return 0;
}

static int parse_box(Parser *P, Loc at)
{
    enum { MIN, MAX, MATERIAL, MATRIX, N = MATRIX + XF_N };
    static const Field f[N] = {{"min", F_VEC}, {"max", F_VEC}, {"material", F_NAME}, XF_FIELDS};
    Value v[N];
    int mat;
    if (parse_block(P, "box", f, N, v) || require(P, "box", f, v, MIN, at) || require(P, "box", f, v, MAX, at) ||
        material_ref(P, "box", f, v, MATERIAL, at, &mat))
        return -1;
    double lo[3], hi[3];
    dvec_of(&v[MIN], lo);
    dvec_of(&v[MAX], hi);
    if (!(lo[0] < hi[0] && lo[1] < hi[1] && lo[2] < hi[2]))
        return fail(P, v[MAX].value, "box: 'max' must exceed 'min' on every axis");
    OBJECT_XF("box");
    if (xf && !xf_axis_aligned(xf)) { /* turned or sheared: an oriented box */
        double c[3], ax[3][3] = {{0}};
        for (int k = 0; k < 3; k++) {
            c[k] = 0.5 * (lo[k] + hi[k]);
            ax[k][k] = 0.5 * (hi[k] - lo[k]);
            xf_dir(xf, ax[k], ax[k]);
        }
        xf_point(xf, c, c);
        return add_obox(P, "box", at, mat, c, ax);
    }
    Place *pl;
    Prim *p = new_prim(P, PRIM_BOX, at, &pl);
    if (!p)
        return -1;
    p->material = mat;
    xf_point(xf, lo, pl->p[0]);
    xf_point(xf, hi, pl->p[1]);
    for (int k = 0; k < 3; k++) /* a negative scale or a quarter turn swaps the ends */
        if (pl->p[0][k] > pl->p[1][k]) {
            double t = pl->p[0][k];
            pl->p[0][k] = pl->p[1][k];
            pl->p[1][k] = t;
        }
    derive(P->s, P->s->nprims - 1);
    return 0;
}

static int parse_obox(Parser *P, Loc at)
{
    enum { CENTER, U, V, W, MATERIAL, MATRIX, N = MATRIX + XF_N };
    static const Field f[N] = {{"center", F_VEC}, {"u", F_VEC}, {"v", F_VEC}, {"w", F_VEC}, {"material", F_NAME},
                               XF_FIELDS};
    Value v[N];
    int mat;
    if (parse_block(P, "obox", f, N, v))
        return -1;
    for (int i = CENTER; i <= W; i++)
        if (require(P, "obox", f, v, i, at))
            return -1;
    if (material_ref(P, "obox", f, v, MATERIAL, at, &mat))
        return -1;
    for (int i = U; i <= W; i++)
        if (nonzero_vec(P, "obox", f[i].key, &v[i]))
            return -1;
    OBJECT_XF("obox");
    double c[3], ax[3][3];
    dvec_of(&v[CENTER], c);
    xf_point(xf, c, c);
    for (int k = 0; k < 3; k++) {
        dvec_of(&v[U + k], ax[k]);
        if (xf)
            xf_dir(xf, ax[k], ax[k]);
    }
    return add_obox(P, "obox", at, mat, c, ax);
}

/* Records that the scene read the file at path. Returns 0, or -1 when out
 * of memory. */
static int add_input(Scene *s, const char *path)
{
    char **in = realloc(s->inputs, sizeof(char *) * (size_t)(s->ninputs + 1));
    if (!in)
        return -1;
    s->inputs = in;
    unsigned char(*d)[SHA256_BYTES] = realloc(s->input_sha256, sizeof *d * (size_t)(s->ninputs + 1));
    if (!d)
        return -1;
    s->input_sha256 = d;
    memset(d[s->ninputs], 0, SHA256_BYTES);
    if (!(in[s->ninputs] = malloc(strlen(path) + 1)))
        return -1;
    strcpy(in[s->ninputs++], path);
    return 0;
}

static int parse_mesh(Parser *P, Loc at)
{
    enum { FILE_, MATERIAL, FLAT, SMOOTH, PN, PN_MODE, MATRIX, N = MATRIX + XF_N };
    static const Field f[N] = {{"file", F_STRING}, {"material", F_NAME}, {"flat", F_FLAG}, {"smooth", F_FLAG},
                               {"pn", F_FLAG},     {"pn_mode", F_NAME},  XF_FIELDS};
    Value v[N];
    int mat, mode;
    if (parse_block(P, "mesh", f, N, v) || require(P, "mesh", f, v, FILE_, at) ||
        material_ref(P, "mesh", f, v, MATERIAL, at, &mat) || pn_mode_of(P, "mesh", &v[PN_MODE], &mode))
        return -1;
    if (v[FLAT].set + v[SMOOTH].set + v[PN].set > 1)
        return fail(P, (v[PN].set ? v[PN] : v[SMOOTH]).key, "mesh: 'flat', 'smooth' and 'pn' exclude each other");
    if (v[PN_MODE].set && !v[PN].set)
        return fail(P, v[PN_MODE].key, "mesh: 'pn_mode' is for a 'pn' mesh");
    OBJECT_XF("mesh");
    if (!v[FILE_].str[0])
        return fail(P, v[FILE_].value, "mesh: 'file' is empty");
    /* A relative path is relative to the scene file's folder, whose own
     * path may be as long as a path can be. */
    char path[AFILE_PATH_MAX + SCENE_PATH_MAX];
    const char *slash = strrchr(P->name, '/');
    int len;
    if (v[FILE_].str[0] != '/' && slash)
        len = snprintf(path, sizeof path, "%.*s/%s", (int)(slash - P->name), P->name, v[FILE_].str);
    else
        len = snprintf(path, sizeof path, "%s", v[FILE_].str);
    if (len < 0 || (size_t)len >= sizeof path)
        return fail(P, v[FILE_].value, "mesh: the path from the scene's folder to the file is too long");
    Mesh m;
    char err[sizeof path + 512]; /* the path, and what is wrong */
    if (add_input(P->s, path) != 0)
        return fail(P, at, "out of memory");
    if (mesh_load(path, &m, err, sizeof err) != 0)
        return fail(P, v[FILE_].value, "mesh: %s", err);
    memcpy(P->s->input_sha256[P->s->ninputs - 1], m.sha256, SHA256_BYTES);
    int smooth = v[SMOOTH].set || v[PN].set, dropped = 0;
    if (smooth && !m.n && mesh_vertex_normals(&m, err, sizeof err) != 0) {
        mesh_free(&m);
        return fail(P, at, "mesh: %s", err);
    }
    if (m.nt == 0) {
        int degenerate = m.degenerate;
        mesh_free(&m);
        if (degenerate)
            return fail(P, v[FILE_].value, "mesh: %s has no triangle with area (%d dropped for having none)", path,
                        degenerate);
        return fail(P, v[FILE_].value, "mesh: %s has no triangles", path);
    }
    const int zero = smooth ? mesh_zero_normal(&m) : -1;
    if (zero >= 0) {
        mesh_free(&m);
        return fail(P, v[FILE_].value,
                    "mesh: %s: its normal %d (counting from 1) has zero length, and a %s mesh shades by its normals "
                    "(without '%s' it is flat)",
                    path, zero + 1, v[PN].set ? "pn" : "smooth", v[PN].set ? "pn" : "smooth");
    }
    const int before = P->s->nprims;
    int rc = v[PN].set ? scene_add_pn_mesh(P->s, &m, mat, mode, xf, &dropped)
                       : scene_add_mesh(P->s, &m, mat, smooth, xf, &dropped);
    P->cap_prims = P->cap_place = P->s->nprims; /* the arrays hold at least this many */
    P->cap_patches = P->s->npatches;
    P->s->degenerate += m.degenerate + dropped + (v[PN].set ? 0 : m.nline);
    mesh_free(&m);
    if (rc != 0)
        return fail(P, at, "mesh: out of memory");
    if (P->s->nprims == before)
        return fail(P, at, "mesh: %s: once transformed, every triangle has no area or leaves the range of floats", path);
    return 0;
}

static int prim_valid(const Scene *s, int i);
static void link_prim(Scene *s, int i);

static int dispatch_statement(Parser *P, Token kw);

/* A statement; the primitives it made must be well formed (prim_valid):
 * a transform can take a shape out of float's range, or flatten it even
 * in double (a box scaled by 1e-45 and moved by 1). */
static int parse_statement(Parser *P)
{
    Token kw = P->tok;
    int before = P->s->nprims;
    if (dispatch_statement(P, kw) != 0)
        return -1;
    for (int i = before; i < P->s->nprims; i++) {
        Prim *pr = &P->s->prims[i];
        const int pn = pr->kind == PRIM_PN, mode = pn ? pr->g.pn.mode : 0;
        link_prim(P->s, i);
        if (pn && mode < 0) /* the image block's, which may come later: any mode is well formed */
            pr->g.pn.mode = PN_EXACT;
        const int ok = prim_valid(P->s, i);
        if (pn)
            pr->g.pn.mode = mode;
        if (!ok)
            return fail(P, kw.loc, "%.*s: its transform leaves it flat or out of float's range", (int)kw.len,
                        kw.start);
    }
    return 0;
}

static int dispatch_statement(Parser *P, Token kw)
{
    char buf[64];
    if (kw.kind != TOK_IDENT)
        return fail(P, kw.loc, "expected a keyword, found %s", tok_desc(&kw, buf, sizeof buf));
    if (!is_keyword(&kw)) {
        /* A word with bytes past ASCII ends the token at the first; the
         * message quotes the whole word, as written. */
        size_t n = kw.len;
        int wide = 0;
        while (n < 40 && kw.start + n < P->end &&
               ((unsigned char)kw.start[n] >= 0x80 || isalnum((unsigned char)kw.start[n]) || kw.start[n] == '_'))
            wide |= (unsigned char)kw.start[n++] >= 0x80;
        if (wide)
            return fail(P, kw.loc, "unknown keyword '%.*s' (keywords and names are ASCII letters, digits and '_')",
                        (int)n, kw.start);
        return fail(P, kw.loc, "unknown keyword %s", tok_desc(&kw, buf, sizeof buf));
    }
    if (next(P))
        return -1;
    if (tok_is(&kw, "image"))
        return parse_image(P, kw.loc);
    if (tok_is(&kw, "camera"))
        return parse_camera(P, kw.loc);
    if (tok_is(&kw, "light"))
        return parse_light(P, kw.loc);
    if (tok_is(&kw, "material"))
        return parse_material(P, kw.loc);
    if (tok_is(&kw, "sphere"))
        return parse_sphere(P, kw.loc);
    if (tok_is(&kw, "plane"))
        return parse_plane(P, kw.loc);
    if (tok_is(&kw, "triangle"))
        return parse_triangle(P, kw.loc, 0);
    if (tok_is(&kw, "smooth_triangle"))
        return parse_triangle(P, kw.loc, 1);
    if (tok_is(&kw, "box"))
        return parse_box(P, kw.loc);
    if (tok_is(&kw, "obox"))
        return parse_obox(P, kw.loc);
    if (tok_is(&kw, "mesh"))
        return parse_mesh(P, kw.loc);
    if (tok_is(&kw, "pn_triangle"))
        return parse_pn_triangle(P, kw.loc);
    if (tok_is(&kw, "keyframe"))
        return parse_keyframe(P, kw.loc);
    return fail(P, kw.loc, "unknown keyword %s", tok_desc(&kw, buf, sizeof buf)); /* not reached */
}

static int has_length(Vec3 v);

/* Triangle i of m mapped by xf into p (double) and, with normals (n not
 * NULL), its vertex normals too. Returns 0 for a triangle to drop: no area,
 * or a point out of float range. One of m's collinear triangles (i >= nt,
 * for a PN patch) needs no area, but its corners not all at one point
 * once rounded, and normals of some length to bend its edges by. */
static int placed_triangle(const Mesh *m, int i, const double *xf, double p[3][3], Vec3 *n)
{
    int ok = 1;
    for (int k = 0; k < 3; k++) {
        Vec3 v = m->v[m->tri[i][k]];
        const double q[3] = {v.x, v.y, v.z};
        xf_point(xf, q, p[k]);
        ok = ok && vec_is_finite(round3(p[k]));
        if (n) {
            Vec3 nv = m->n[m->ntri[i][k]];
            double d[3] = {nv.x, nv.y, nv.z};
            xf_normal(xf, d, d);
            n[k] = round3(d);
            ok = ok && vec_is_finite(n[k]);
        }
    }
    if (i >= m->nt) {
        const Vec3 a = round3(p[0]), b = round3(p[1]), c = round3(p[2]);
        const int one_point = a.x == b.x && a.y == b.y && a.z == b.z && b.x == c.x && b.y == c.y && b.z == c.z;
        return ok && !one_point && has_length(n[0]) && has_length(n[1]) && has_length(n[2]);
    }
    return ok && tri_has_area_d(p[0], p[1], p[2]);
}

/* Room for need primitives and their places. Returns 0, or -1. */
static int reserve_prims(Scene *s, size_t need)
{
    if (need > (size_t)INT32_MAX)
        return -1;
    Prim *arr = big_realloc(s->prims, sizeof(Prim) * (size_t)s->nprims, sizeof(Prim) * (need ? need : 1));
    if (!arr)
        return -1;
    s->prims = arr;
    Place *pl = big_realloc(s->place, sizeof(Place) * (size_t)s->nprims, sizeof(Place) * (need ? need : 1));
    if (!pl)
        return -1;
    s->place = pl;
    return 0;
}

int scene_add_mesh(Scene *s, const Mesh *m, int material, int smooth, const double *xf, int *dropped)
{
    if (reserve_prims(s, (size_t)s->nprims + (size_t)m->nt) != 0)
        return -1;
    *dropped = 0;
    const int solid = ++s->nmeshes;
    for (int i = 0; i < m->nt; i++) {
        Prim *p = &s->prims[s->nprims];
        Place *pl = &s->place[s->nprims];
        memset(p, 0, sizeof *p);
        p->kind = smooth ? PRIM_SMOOTH_TRIANGLE : PRIM_TRIANGLE;
        p->material = material;
        p->g.tri.solid = solid;
        Vec3 n[3];
        if (!placed_triangle(m, i, xf, pl->p, smooth ? n : NULL)) {
            (*dropped)++;
            continue;
        }
        if (smooth)
            p->g.tri.na = n[0], p->g.tri.nb = n[1], p->g.tri.nc = n[2];
        derive(s, s->nprims++);
    }
    return 0;
}

/* Points every PN primitive at its patch and every ellipsoid at its own:
 * after their arrays have moved. */
static void link_prim(Scene *s, int i)
{
    if (s->prims[i].kind == PRIM_PN)
        s->prims[i].g.pn.patch = &s->patches[s->prims[i].g.pn.index];
    if (s->prims[i].kind == PRIM_ELLIPSOID)
        s->prims[i].g.ell.e = &s->ellipsoids[s->prims[i].g.ell.index];
}

static void link_patches(Scene *s)
{
    for (int i = 0; i < s->nprims; i++)
        link_prim(s, i);
}

int scene_add_pn_mesh(Scene *s, const Mesh *m, int material, int mode, const double *xf, int *dropped)
{
    const int all = m->nt + m->nline; /* the collinear ones too: their patches have area */
    size_t needp = (size_t)s->npatches + (size_t)all;
    if (needp > (size_t)INT32_MAX || !m->n || reserve_prims(s, (size_t)s->nprims + (size_t)all) != 0)
        return -1;
    PnPatch *pa = big_realloc(s->patches, sizeof(PnPatch) * (size_t)s->npatches, sizeof(PnPatch) * (needp ? needp : 1));
    if (!pa)
        return -1;
    s->patches = pa;
    *dropped = 0;
    const int solid = ++s->nmeshes;
    for (int i = 0; i < all; i++) {
        Place *pl = &s->place[s->nprims];
        Vec3 n[3];
        if (!placed_triangle(m, i, xf, pl->p, n)) {
            (*dropped)++;
            continue;
        }
        const Vec3 p[3] = {round3(pl->p[0]), round3(pl->p[1]), round3(pl->p[2])};
        pn_patch_init(&s->patches[s->npatches], p, n);
        Prim *q = &s->prims[s->nprims++];
        memset(q, 0, sizeof *q);
        q->kind = PRIM_PN;
        q->material = material;
        q->g.pn.solid = solid;
        q->g.pn.index = s->npatches++;
        q->g.pn.mode = mode;
    }
    link_patches(s);
    return 0;
}

Place scene_place(const Scene *s, int i)
{
    if (s->place)
        return s->place[i];
    const Prim *p = &s->prims[i];
    Vec3 v[3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    switch (p->kind) {
    case PRIM_SPHERE:
        v[0] = p->g.sphere.c, v[1].x = p->g.sphere.r;
        break;
    case PRIM_PLANE:
        v[0] = p->g.plane.n, v[1].x = p->g.plane.d;
        break;
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE:
        v[0] = p->g.tri.a, v[1] = p->g.tri.b, v[2] = p->g.tri.c;
        break;
    case PRIM_BOX:
        v[0] = p->g.box.lo, v[1] = p->g.box.hi;
        break;
    case PRIM_OBOX:
        v[0] = p->g.obox.c;
        break;
    case PRIM_PN: /* the patch's corners */
        v[0] = p->g.pn.patch->b[PN_AT(3, 0)], v[1] = p->g.pn.patch->b[PN_AT(0, 0)];
        v[2] = p->g.pn.patch->b[PN_AT(0, 3)];
        break;
    case PRIM_ELLIPSOID:
        break;
    }
    Place q;
    for (int j = 0; j < 3; j++)
        for (int k = 0; k < 3; k++)
            q.p[j][k] = vec_comp(v[j], k);
    return q;
}

/* Places from the floats, for a scene built in code (Scene.place). */
static int place_from_floats(Scene *s)
{
    if (!s->placed) {
        CameraSpec *c = &s->camera;
        for (int k = 0; k < 3; k++) {
            c->eye_at[k] = vec_comp(c->eye, k);
            c->target_at[k] = vec_comp(c->target, k);
        }
        for (int i = 0; i < s->nlights; i++)
            for (int k = 0; k < 3; k++)
                s->lights[i].at[k] = vec_comp(s->lights[i].pos, k);
        s->placed = 1;
    }
    if (s->place || s->nprims == 0)
        return 0;
    Place *pl = malloc(sizeof(Place) * (size_t)s->nprims);
    if (!pl)
        return -1;
    for (int i = 0; i < s->nprims; i++)
        pl[i] = scene_place(s, i);
    s->place = pl;
    return 0;
}

/* p * scale + offset, in place. */
static void move(double p[3], double scale, const double offset[3])
{
    for (int k = 0; k < 3; k++)
        p[k] = p[k] * scale + offset[k];
}

static Vec3 scaled(Vec3 v, double scale)
{
    return vec3((float)(v.x * scale), (float)(v.y * scale), (float)(v.z * scale));
}

/* 1 when q, a box or triangle of kind `kind`, has extent in double. */
static int has_extent(PrimKind kind, const Place *q)
{
    if (kind == PRIM_BOX)
        return q->p[0][0] < q->p[1][0] && q->p[0][1] < q->p[1][1] && q->p[0][2] < q->p[1][2];
    return (kind != PRIM_TRIANGLE && kind != PRIM_SMOOTH_TRIANGLE && kind != PRIM_PN) ||
           tri_has_area_d(q->p[0], q->p[1], q->p[2]);
}

/* 1 when the move left box or triangle q, which had extent before it (as
 * `was`), with none in double, so that no ray can hit it; a box flat along
 * one axis only still shows its faces, and is kept one double thick. */
static int vanished(PrimKind kind, Place *q, const Place *was)
{
    if (has_extent(kind, q) || !has_extent(kind, was))
        return 0; /* intact, or degenerate already: scene_validate says so */
    if (kind == PRIM_BOX) {
        int flat = 0, axis = 0;
        for (int k = 0; k < 3; k++)
            if (q->p[0][k] == q->p[1][k])
                flat++, axis = k;
        if (flat == 1) /* the far side, rounded outwards */
            q->p[1][axis] = nextafter(q->p[1][axis], INFINITY);
        return flat > 1;
    }
    return 1;
}

int scene_transform(Scene *s, double scale, const double offset[3])
{
    if (place_from_floats(s) != 0)
        return -1;
    CameraSpec *c = &s->camera;
    move(c->eye_at, scale, offset);
    move(c->target_at, scale, offset);
    c->eye = round3(c->eye_at);
    c->target = round3(c->target_at);
    for (int i = 0; i < s->nlights; i++) {
        Light *l = &s->lights[i];
        move(l->at, scale, offset);
        l->pos = round3(l->at);
        l->area_u = scaled(l->area_u, scale);
        l->area_v = scaled(l->area_v, scale);
        l->fade_distance = (float)(l->fade_distance * scale);
    }
    int kept = 0, gone = 0;
    for (int i = 0; i < s->nprims; i++) {
        Prim *p = &s->prims[i];
        Place *q = &s->place[i], was = *q;
        switch (p->kind) {
        case PRIM_SPHERE:
            move(q->p[0], scale, offset);
            q->p[1][0] *= scale;
            break;
        case PRIM_PLANE: /* n.p = d becomes n.p' = d*scale + n.offset */
            q->p[1][0] = q->p[1][0] * scale + q->p[0][0] * offset[0] + q->p[0][1] * offset[1] + q->p[0][2] * offset[2];
            break;
        case PRIM_TRIANGLE:
        case PRIM_SMOOTH_TRIANGLE:
        case PRIM_PN:
            for (int k = 0; k < 3; k++)
                move(q->p[k], scale, offset);
            break;
        case PRIM_BOX:
            move(q->p[0], scale, offset);
            move(q->p[1], scale, offset);
            break;
        case PRIM_OBOX:
            move(q->p[0], scale, offset);
            p->g.obox.u = scaled(p->g.obox.u, scale);
            p->g.obox.v = scaled(p->g.obox.v, scale);
            p->g.obox.w = scaled(p->g.obox.w, scale);
            break;
        case PRIM_ELLIPSOID: {
            Ellipsoid *e = &s->ellipsoids[p->g.ell.index];
            for (int k = 0; k < 9; k++)
                e->m[k] *= scale;
            move(e->m + 9, scale, offset);
            if (prim_ellipsoid_init(e) != 0)
                return -1;
            break;
        }
        }
        /* A shape thinner than a double's step where it now lies, next to
         * a camera far out, is one no ray can hit: it leaves the scene,
         * rather than fail it for a rounding lancer chose. */
        if (vanished(p->kind, q, &was)) {
            if (!s->origin) { /* from now on primitive k is the file's origin[k] */
                if (!(s->origin = malloc(sizeof(int) * (size_t)s->nprims)))
                    return -1;
                for (int k = 0; k < s->nprims; k++)
                    s->origin[k] = k;
            }
            gone++;
            continue;
        }
        if (kept != i) {
            s->prims[kept] = *p;
            s->place[kept] = *q;
            s->origin[kept] = s->origin[i];
        }
        if (derive(s, kept++) != 0)
            return -1;
    }
    s->nprims = kept;
    s->vanished += gone;
    char err[128];
    return scene_validate(s, err, sizeof err); /* nothing overflowed or collapsed */
}

/* 1 when v is finite and not zero. */
static int has_length(Vec3 v) { return vec_is_finite(v) && vec_length(v) > 0.0f && isfinite(vec_length(v)); }

/* 1 when primitive i of s is well formed: finite floats, and a shape with
 * extent, judged by its doubles where it has them (a small object far out
 * may round to a line in float, which no ray then hits). */
static int prim_valid(const Scene *s, int i)
{
    const Prim *p = &s->prims[i];
    int ok = 1;
    switch (p->kind) {
    case PRIM_SPHERE:
        ok = vec_is_finite(p->g.sphere.c) && p->g.sphere.r > 0.0f && isfinite(p->g.sphere.r);
        break;
    case PRIM_PLANE:
        ok = has_length(p->g.plane.n) && isfinite(p->g.plane.d);
        break;
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE: {
        /* the shape as placed, in double: far from the camera, a small
         * triangle may round to a line, which no ray then hits */
        const Triangle *t = &p->g.tri;
        const Place *q = s->place ? &s->place[i] : NULL;
        ok = vec_is_finite(t->a) && vec_is_finite(t->b) && vec_is_finite(t->c) &&
             (q ? has_extent(p->kind, q) : tri_has_area(t->a, t->b, t->c));
        if (p->kind == PRIM_SMOOTH_TRIANGLE)
            ok = ok && has_length(t->na) && has_length(t->nb) && has_length(t->nc);
        break;
    }
    case PRIM_BOX: {
        const Box *b = &p->g.box;
        const Place *q = s->place ? &s->place[i] : NULL;
        ok = vec_is_finite(b->lo) && vec_is_finite(b->hi) &&
             (q ? has_extent(PRIM_BOX, q) : b->lo.x < b->hi.x && b->lo.y < b->hi.y && b->lo.z < b->hi.z);
        break;
    }
    case PRIM_OBOX: {
        OBox b = p->g.obox;
        ok = vec_is_finite(b.c) && prim_obox_init(&b) == 0;
        break;
    }
    case PRIM_PN: {
        const PnRef *r = &p->g.pn;
        ok = r->index >= 0 && r->index < s->npatches && r->patch == &s->patches[r->index] &&
             (r->mode == PN_EXACT || r->mode == PN_FAST);
        for (int k = 0; ok && k < 10; k++)
            ok = vec_is_finite(r->patch->b[k]);
        for (int k = 0; ok && k < 6; k++)
            ok = has_length(r->patch->n[k]);
        break;
    }
    case PRIM_ELLIPSOID: {
        const EllRef *r = &p->g.ell;
        ok = r->index >= 0 && r->index < s->nellipsoids && r->e == &s->ellipsoids[r->index];
        if (ok) {
            Ellipsoid e = *r->e;
            ok = prim_ellipsoid_init(&e) == 0;
        }
        break;
    }
    default:
        ok = 0;
    }
    return ok;
}

long long scene_light_samples(const Scene *s)
{
    long long n = 0;
    for (int i = 0; i < s->nlights; i++)
        n += (long long)s->lights[i].area_n1 * s->lights[i].area_n2;
    return n;
}

int scene_validate(const Scene *s, char *err, size_t errlen)
{
#define BAD(...) return snprintf(err, errlen, __VA_ARGS__), -1
    const SceneImage *im = &s->image;
    if (im->width < 1 || im->width > LIMIT_IMAGE_SIDE || im->height < 1 || im->height > LIMIT_IMAGE_SIDE ||
        (long)im->width * im->height > LIMIT_IMAGE_PIXELS)
        BAD("image size %dx%d out of range", im->width, im->height);
    if (im->spp < 1 || im->spp > LIMIT_SPP || im->max_depth < 1 || im->max_depth > LIMIT_DEPTH)
        BAD("spp %d or max_depth %d out of range", im->spp, im->max_depth);
    if (!vec_is_finite(s->background))
        BAD("background is not finite");
    const CameraSpec *c = &s->camera;
    Vec3 fwd = vec_sub(c->target, c->eye);
    if (s->placed) /* the view direction in double: eye and target far out may round to one float */
        fwd = vec3((float)(c->target_at[0] - c->eye_at[0]), (float)(c->target_at[1] - c->eye_at[1]),
                   (float)(c->target_at[2] - c->eye_at[2]));
    if (!vec_is_finite(c->eye) || !vec_is_finite(c->target) || !has_length(fwd) || !has_length(c->up) ||
        !(vec_length(vec_cross(vec_normalize(fwd), vec_normalize(c->up))) > 1e-6f) ||
        !(c->fovy > 0.0f && c->fovy < 180.0f))
        BAD("camera degenerates");
    for (int i = 0; i < s->nmaterials; i++) {
        const Material *m = &s->materials[i];
        const float f[] = {m->color.x, m->color.y, m->color.z, m->ambient, m->diffuse, m->phong, m->phong_size,
                           m->specular, m->roughness, m->reflection, m->filter, m->transmit, m->ior};
        for (size_t k = 0; k < sizeof f / sizeof f[0]; k++)
            if (!(f[k] >= 0.0f) || !isfinite(f[k]))
                BAD("material %d: a value is negative or not finite", i);
        if (!(m->roughness > 0.0f) || !(m->ior > 0.0f) || m->filter + m->transmit > 1.0f)
            BAD("material %d: roughness, ior, or filter and transmit out of range", i);
    }
    for (int i = 0; i < s->nlights; i++) {
        const Light *l = &s->lights[i];
        if (!vec_is_finite(l->pos) || !vec_is_finite(l->color) || !vec_is_finite(l->area_u) ||
            !vec_is_finite(l->area_v) || !isfinite(l->fade_distance) || !(l->fade_power >= 0.0f) ||
            !isfinite(l->fade_power) || (l->fade_power > 0.0f && !(l->fade_distance > 0.0f)))
            BAD("light %d is not finite or its fade is out of range", i);
        if (l->area_n1 < 1 || l->area_n1 > LIMIT_AREA_SAMPLES || l->area_n2 < 1 ||
            l->area_n2 > LIMIT_AREA_SAMPLES || l->adaptive < 0 || l->adaptive > LIMIT_AREA_ADAPTIVE + 1)
            BAD("light %d: area samples out of range", i);
    }
    if (scene_light_samples(s) > LIMIT_LIGHT_SAMPLES)
        BAD("the lights take more than %d samples in all", LIMIT_LIGHT_SAMPLES);
    for (int i = 0; i < s->nprims; i++) {
        const Prim *p = &s->prims[i];
        if (p->material < 0 || p->material >= s->nmaterials)
            BAD("primitive %d: material %d out of range", i, p->material);
        if (!prim_valid(s, i))
            BAD("primitive %d degenerates or is not finite", i);
    }
    if (s->degenerate < 0)
        BAD("negative count of degenerate triangles");
    if (im->pn_mode != PN_EXACT && im->pn_mode != PN_FAST)
        BAD("pn_mode %d out of range", im->pn_mode);
    return 0;
#undef BAD
}

/* pn: 0 for flat triangles, or 1 + the PnMode of PN patches. */
static int scene_of_mesh(Scene *s, const Mesh *m, int pn)
{
    memset(s, 0, sizeof *s);
    s->materials = calloc(1, sizeof(Material));
    s->nmaterials = s->materials ? 1 : 0;
    int dropped;
    if (!s->materials || (pn ? scene_add_pn_mesh(s, m, 0, pn - 1, NULL, &dropped)
                             : scene_add_mesh(s, m, 0, 0, NULL, &dropped)) != 0) {
        scene_free(s);
        return -1;
    }
    return 0;
}

int scene_from_mesh(Scene *s, const Mesh *m) { return scene_of_mesh(s, m, 0); }

int scene_from_pn_mesh(Scene *s, const Mesh *m, int mode) { return scene_of_mesh(s, m, 1 + mode); }

int scene_split_triangles(Scene *s)
{
    int ntri = 0;
    for (int i = 0; i < s->nprims; i++)
        ntri += s->prims[i].kind == PRIM_TRIANGLE || s->prims[i].kind == PRIM_SMOOTH_TRIANGLE;
    size_t n = (size_t)s->nprims + (size_t)ntri;
    if (n > (size_t)INT32_MAX || place_from_floats(s) != 0)
        return -1;
    Prim *np = malloc(sizeof(Prim) * (n ? n : 1));
    Place *nq = malloc(sizeof(Place) * (n ? n : 1));
    if (!np || !nq) {
        free(np);
        free(nq);
        return -1;
    }
    size_t k = 0;
    for (int i = 0; i < s->nprims; i++) {
        const Prim *p = &s->prims[i];
        np[k] = *p;
        nq[k] = s->place[i];
        if (p->kind != PRIM_TRIANGLE && p->kind != PRIM_SMOOTH_TRIANGLE) {
            k++;
            continue;
        }
        const Triangle *t = &p->g.tri;
        const Place *v = &s->place[i];
        Vec3 nv[3] = {t->na, t->nb, t->nc};
        int c = 0; /* the corner opposite the longest edge */
        double best = -1.0;
        for (int j = 0; j < 3; j++) {
            double e2 = 0.0;
            for (int a = 0; a < 3; a++)
                e2 += (v->p[(j + 1) % 3][a] - v->p[(j + 2) % 3][a]) * (v->p[(j + 1) % 3][a] - v->p[(j + 2) % 3][a]);
            if (e2 > best) {
                best = e2;
                c = j;
            }
        }
        int b = (c + 1) % 3, d = (c + 2) % 3;
        double m[3];
        for (int a = 0; a < 3; a++)
            m[a] = 0.5 * (v->p[b][a] + v->p[d][a]);
        Vec3 nm = vec_normalize(vec_add(nv[b], nv[d]));
        np[k + 1] = np[k];
        Triangle *t0 = &np[k].g.tri, *t1 = &np[k + 1].g.tri;
        t0->na = nv[c], t0->nb = nv[b], t0->nc = nm;
        t1->na = nv[c], t1->nb = nm, t1->nc = nv[d];
        const double *c0[3] = {v->p[c], v->p[b], m}, *c1[3] = {v->p[c], m, v->p[d]};
        for (int j = 0; j < 3; j++) {
            memcpy(nq[k].p[j], c0[j], sizeof(double) * 3);
            memcpy(nq[k + 1].p[j], c1[j], sizeof(double) * 3);
        }
        k += 2;
    }
    free(s->prims);
    free(s->place);
    s->prims = np;
    s->place = nq;
    s->nprims = (int)n;
    for (int i = 0; i < s->nprims; i++)
        derive(s, i);
    return 0;
}

void scene_free(Scene *s)
{
    free(s->materials);
    free(s->keys);
    free(s->lights);
    free(s->prims);
    free(s->place);
    free(s->patches);
    free(s->ellipsoids);
    free(s->ellipsoid_at);
    free(s->origin);
    for (int i = 0; i < s->ninputs; i++)
        free(s->inputs[i]);
    free(s->inputs);
    free(s->input_sha256);
    memset(s, 0, sizeof *s);
}

void scene_content_hash(const Scene *s, char hex[SHA256_HEX])
{
    Sha256 h;
    unsigned char d[SHA256_BYTES];
    sha256_init(&h);
    for (int i = 0; i < s->ninputs; i++)
        sha256_update(&h, s->input_sha256[i], SHA256_BYTES);
    sha256_final(&h, d);
    sha256_hex(d, hex);
}

int scene_parse(const char *name, const char *text, size_t len, Scene *s, char *err, size_t errlen)
{
    Parser P;
    memset(&P, 0, sizeof P);
    memset(s, 0, sizeof *s);
    P.name = name;
    P.p = text;
    P.end = text + len;
    P.p += lex_bom_len(P.p, P.end);
    P.at.line = 1;
    P.at.col = 1;
    P.err = err;
    P.errlen = errlen;
    P.name_seed = lex_hash_seed();
    P.s = s;
    s->image.width = 640;
    s->image.height = 480;
    s->image.max_depth = 5; /* POV-Ray's default max_trace_level */
    s->image.spp = 1;
    s->image.adc_bailout = SCENE_ADC_BAILOUT;
    int rc = next(&P);
    while (rc == 0 && P.tok.kind != TOK_EOF)
        rc = parse_statement(&P);
    if (rc == 0 && !P.have_camera)
        rc = fail(&P, P.tok.loc, "the scene has no 'camera' block");
    free(P.names);
    if (rc != 0) {
        scene_free(s);
        return rc;
    }
    for (int i = 0; i < s->nkeys; i++)
        if (s->keys[i].fov < 0.0)
            s->keys[i].fov = s->camera.fovy;
    /* Patches without a pn_mode of their own take the image block's, which
     * may come after them. */
    for (int i = 0; i < s->nprims; i++)
        if (s->prims[i].kind == PRIM_PN && s->prims[i].g.pn.mode < 0)
            s->prims[i].g.pn.mode = s->image.pn_mode;
    link_patches(s);
    s->placed = 1;
    return 0;
}

int scene_load(const char *path, Scene *s, char *err, size_t errlen)
{
    memset(s, 0, sizeof *s);
    char *buf;
    size_t len;
    if (afile_read(path, (unsigned long long)LIMIT_SCENE_BYTES, "scenes", &buf, &len, err, errlen) != 0)
        return -1;
    int rc = scene_parse(path, buf, len, s, err, errlen);
    if (rc == 0 && add_input(s, path) != 0) {
        snprintf(err, errlen, "%s: out of memory", path);
        scene_free(s);
        rc = -1;
    }
    if (rc == 0) {
        Sha256 h;
        sha256_init(&h);
        sha256_update(&h, buf, len);
        sha256_final(&h, s->input_sha256[s->ninputs - 1]);
    }
    free(buf);
    return rc;
}
