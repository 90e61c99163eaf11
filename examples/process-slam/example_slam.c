/*
 * example_slam.c -- a complete SLAM for faultlab's process protocol (version 1), in C99 with the C
 * library only.  Build:  cc -O2 -std=c99 -o example_slam example_slam.c -lm
 *
 * Algorithm: dead reckoning plus landmark averaging.  The pose is the integral of the measured
 * controls (drive v along the heading, then turn by omega; the heading wrapped to [-pi, pi)); every
 * observed landmark is placed at the mean of its observations, each projected from the pose at
 * which it was made.  Deterministic: the seed of a reset is read and not needed.
 *
 * Protocol (docs/reference/process-protocol.md): one JSON object per line on stdin, one reply per
 * line on stdout, nothing else on stdout; diagnostics go to stderr.
 *   {"type":"reset","protocol":1,"pose":[x,y,theta],"seed":s}  ->  {"type":"ready","protocol":1}
 *   {"type":"step","t":k,"control":[v,omega],"ranges":[..],"bearings":[..],"ids":[..]}
 *                                                              ->  {"type":"ack","t":k}
 *   {"type":"estimate"}  ->  {"type":"estimate","pose":[x,y,theta],"landmarks":[[id,x,y],...],
 *                              "trajectory":[[x,y,theta],...]}   (the pose after every step)
 *   {"type":"bye"}       ->  exit status 0, no reply
 * Anything it cannot process is answered with {"type":"error","message":"..."}.
 *
 * Run standalone on a transcript written by `faultlab export CASE --format jsonl --out D`:
 *   ./example_slam < D/case.jsonl          (the last line printed is the estimate)
 *
 * Deliberate defects, for testing the tools that check a process SLAM:
 *   EXAMPLE_SLAM_KILL_AT_STEP=k   at step k, write a note to stderr and kill itself with SIGKILL
 *   EXAMPLE_SLAM_BREAK=estimate   reply to "estimate" with landmarks as [x,y] (no id): malformed
 *   EXAMPLE_SLAM_BREAK=trajectory reply to "estimate" with trajectory poses as [x,y] (no heading): malformed
 */
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PROTOCOL 1
#define PI 3.14159265358979323846

/* ------------------------------------------------------------------ growable arrays */
typedef struct {
    double *v;
    size_t n, cap;
} vec;

static void vec_push(vec *a, double x) {
    if (a->n == a->cap) {
        a->cap = a->cap ? 2 * a->cap : 16;
        a->v = realloc(a->v, a->cap * sizeof(double));
        if (!a->v) {
            fprintf(stderr, "example_slam: out of memory\n");
            exit(3);
        }
    }
    a->v[a->n++] = x;
}

/* ------------------------------------------------------------------ a small JSON reader */
typedef struct {
    const char *s;
    const char *err; /* first error, or NULL */
} cursor;

static void skip_ws(cursor *c) {
    while (*c->s == ' ' || *c->s == '\t' || *c->s == '\r' || *c->s == '\n') c->s++;
}

static int fail(cursor *c, const char *what) {
    if (!c->err) c->err = what;
    return 0;
}

static int expect(cursor *c, char ch) {
    skip_ws(c);
    if (*c->s != ch) return fail(c, "unexpected character");
    c->s++;
    return 1;
}

/* A string into out (at most cap - 1 bytes kept; escapes decoded, \u as '?'). */
static int read_string(cursor *c, char *out, size_t cap) {
    size_t n = 0;
    if (!expect(c, '"')) return 0;
    while (*c->s && *c->s != '"') {
        char ch = *c->s++;
        if (ch == '\\') {
            ch = *c->s++;
            switch (ch) {
            case 'n': ch = '\n'; break;
            case 't': ch = '\t'; break;
            case 'r': ch = '\r'; break;
            case 'b': ch = '\b'; break;
            case 'f': ch = '\f'; break;
            case 'u':
                for (int i = 0; i < 4; i++)
                    if (!isxdigit((unsigned char)*c->s++)) return fail(c, "bad \\u escape");
                ch = '?';
                break;
            case '"': case '\\': case '/': break;
            default: return fail(c, "bad escape in string");
            }
        }
        if (out && n + 1 < cap) out[n++] = ch;
    }
    if (*c->s != '"') return fail(c, "unterminated string");
    c->s++;
    if (out) out[n] = '\0';
    return 1;
}

static int read_number(cursor *c, double *x) {
    char *end;
    skip_ws(c);
    if (!(*c->s == '-' || isdigit((unsigned char)*c->s))) return fail(c, "expected a number");
    *x = strtod(c->s, &end);
    if (end == c->s) return fail(c, "expected a number");
    c->s = end;
    return 1;
}

static int skip_value(cursor *c, int depth) {
    double x;
    skip_ws(c);
    if (depth > 64) return fail(c, "nesting too deep");
    switch (*c->s) {
    case '"': return read_string(c, NULL, 0);
    case '{':
    case '[': {
        char close = *c->s == '{' ? '}' : ']';
        int object = *c->s == '{';
        c->s++;
        skip_ws(c);
        if (*c->s == close) { c->s++; return 1; }
        for (;;) {
            if (object && !(read_string(c, NULL, 0) && expect(c, ':'))) return 0;
            if (!skip_value(c, depth + 1)) return 0;
            skip_ws(c);
            if (*c->s == ',') { c->s++; continue; }
            return expect(c, close);
        }
    }
    default:
        if (!strncmp(c->s, "true", 4)) { c->s += 4; return 1; }
        if (!strncmp(c->s, "false", 5)) { c->s += 5; return 1; }
        if (!strncmp(c->s, "null", 4)) { c->s += 4; return 1; }
        return read_number(c, &x);
    }
}

/* An array of numbers, appended to out. */
static int read_numbers(cursor *c, vec *out) {
    double x;
    if (!expect(c, '[')) return 0;
    skip_ws(c);
    if (*c->s == ']') { c->s++; return 1; }
    for (;;) {
        if (!read_number(c, &x)) return 0;
        vec_push(out, x);
        skip_ws(c);
        if (*c->s == ',') { c->s++; continue; }
        return expect(c, ']');
    }
}

typedef struct {
    char type[32];
    double protocol, t;
    int has_protocol, has_t;
    vec pose, control, ranges, bearings, ids;
} message;

static int read_message(const char *line, message *m) {
    cursor c = {line, NULL};
    char key[64];
    m->type[0] = '\0';
    m->has_protocol = m->has_t = 0;
    m->pose.n = m->control.n = m->ranges.n = m->bearings.n = m->ids.n = 0;
    if (!expect(&c, '{')) return 0;
    skip_ws(&c);
    if (*c.s == '}') c.s++;
    else for (;;) {
        int ok;
        if (!(read_string(&c, key, sizeof key) && expect(&c, ':'))) return 0;
        if (!strcmp(key, "type")) ok = read_string(&c, m->type, sizeof m->type);
        else if (!strcmp(key, "protocol")) ok = m->has_protocol = read_number(&c, &m->protocol);
        else if (!strcmp(key, "t")) ok = m->has_t = read_number(&c, &m->t);
        else if (!strcmp(key, "pose")) ok = read_numbers(&c, &m->pose);
        else if (!strcmp(key, "control")) ok = read_numbers(&c, &m->control);
        else if (!strcmp(key, "ranges")) ok = read_numbers(&c, &m->ranges);
        else if (!strcmp(key, "bearings")) ok = read_numbers(&c, &m->bearings);
        else if (!strcmp(key, "ids")) ok = read_numbers(&c, &m->ids);
        else ok = skip_value(&c, 0); /* e.g. "seed": not needed by a deterministic SLAM */
        if (!ok) return 0;
        skip_ws(&c);
        if (*c.s == ',') { c.s++; continue; }
        if (!expect(&c, '}')) return 0;
        break;
    }
    skip_ws(&c);
    return *c.s == '\0' ? 1 : fail(&c, "text after the object");
}

/* ------------------------------------------------------------------ the SLAM */
static double pose[3];
static int started = 0;
static long long *lm_id = NULL; /* sorted */
static double *lm_sx = NULL, *lm_sy = NULL;
static long *lm_n = NULL;
static size_t n_lm = 0, cap_lm = 0;
static vec traj; /* x, y, theta after every step since the reset */

static double wrap(double a) { return a - 2.0 * PI * floor((a + PI) / (2.0 * PI)); }

/* Index of landmark id, inserted with zero sums if new. */
static size_t landmark(long long id) {
    size_t lo = 0, hi = n_lm;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (lm_id[mid] < id) lo = mid + 1;
        else hi = mid;
    }
    if (lo < n_lm && lm_id[lo] == id) return lo;
    if (n_lm == cap_lm) {
        cap_lm = cap_lm ? 2 * cap_lm : 64;
        lm_id = realloc(lm_id, cap_lm * sizeof *lm_id);
        lm_sx = realloc(lm_sx, cap_lm * sizeof *lm_sx);
        lm_sy = realloc(lm_sy, cap_lm * sizeof *lm_sy);
        lm_n = realloc(lm_n, cap_lm * sizeof *lm_n);
        if (!lm_id || !lm_sx || !lm_sy || !lm_n) {
            fprintf(stderr, "example_slam: out of memory\n");
            exit(3);
        }
    }
    size_t tail = n_lm - lo;
    memmove(lm_id + lo + 1, lm_id + lo, tail * sizeof *lm_id);
    memmove(lm_sx + lo + 1, lm_sx + lo, tail * sizeof *lm_sx);
    memmove(lm_sy + lo + 1, lm_sy + lo, tail * sizeof *lm_sy);
    memmove(lm_n + lo + 1, lm_n + lo, tail * sizeof *lm_n);
    lm_id[lo] = id;
    lm_sx[lo] = lm_sy[lo] = 0.0;
    lm_n[lo] = 0;
    n_lm++;
    return lo;
}

static void reply_error(const char *what) {
    printf("{\"type\":\"error\",\"message\":\"");
    for (const char *p = what; *p; p++) {
        if (*p == '"' || *p == '\\') putchar('\\');
        putchar(*p == '\n' ? ' ' : *p);
    }
    printf("\"}\n");
}

static void handle(const message *m, int broken_estimate, int broken_trajectory, long kill_at) {
    if (!strcmp(m->type, "reset")) {
        if (!m->has_protocol || m->protocol != PROTOCOL) {
            reply_error("unsupported protocol version (this program speaks version 1)");
            return;
        }
        if (m->pose.n != 3) {
            reply_error("reset: pose must be [x, y, theta]");
            return;
        }
        memcpy(pose, m->pose.v, sizeof pose);
        pose[2] = wrap(pose[2]);
        n_lm = 0;
        traj.n = 0;
        started = 1;
        printf("{\"type\":\"ready\",\"protocol\":%d}\n", PROTOCOL);
    } else if (!strcmp(m->type, "step")) {
        size_t k = m->ranges.n;
        if (!started) { reply_error("step before reset"); return; }
        if (m->control.n != 2) { reply_error("step: control must be [v, omega]"); return; }
        if (m->bearings.n != k || m->ids.n != k) {
            reply_error("step: ranges, bearings and ids must have equal lengths");
            return;
        }
        if (kill_at >= 0 && m->has_t && (long)m->t == kill_at) {
            fprintf(stderr, "example_slam: step %ld received; killing myself (EXAMPLE_SLAM_KILL_AT_STEP)\n",
                    kill_at);
            fflush(stderr);
            raise(SIGKILL);
        }
        double v = m->control.v[0], omega = m->control.v[1];
        pose[0] += v * cos(pose[2]);
        pose[1] += v * sin(pose[2]);
        pose[2] = wrap(pose[2] + omega);
        for (size_t i = 0; i < k; i++) {
            double a = pose[2] + m->bearings.v[i], r = m->ranges.v[i];
            size_t j = landmark((long long)m->ids.v[i]);
            lm_sx[j] += pose[0] + r * cos(a);
            lm_sy[j] += pose[1] + r * sin(a);
            lm_n[j] += 1;
        }
        for (int i = 0; i < 3; i++) vec_push(&traj, pose[i]);
        if (m->has_t) printf("{\"type\":\"ack\",\"t\":%.17g}\n", m->t);
        else printf("{\"type\":\"ack\"}\n");
    } else if (!strcmp(m->type, "estimate")) {
        if (!started) { reply_error("estimate before reset"); return; }
        printf("{\"type\":\"estimate\",\"pose\":[%.17g,%.17g,%.17g],\"landmarks\":[", pose[0], pose[1], pose[2]);
        for (size_t j = 0; j < n_lm; j++) {
            double x = lm_sx[j] / (double)lm_n[j], y = lm_sy[j] / (double)lm_n[j];
            if (broken_estimate) printf("%s[%.17g,%.17g]", j ? "," : "", x, y);
            else printf("%s[%lld,%.17g,%.17g]", j ? "," : "", lm_id[j], x, y);
        }
        printf("],\"trajectory\":[");
        for (size_t t = 0; 3 * t < traj.n; t++) {
            const double *p = traj.v + 3 * t;
            if (broken_trajectory) printf("%s[%.17g,%.17g]", t ? "," : "", p[0], p[1]);
            else printf("%s[%.17g,%.17g,%.17g]", t ? "," : "", p[0], p[1], p[2]);
        }
        printf("]}\n");
    } else if (!strcmp(m->type, "bye")) {
        exit(0);
    } else {
        reply_error("unknown message type");
    }
}

int main(void) {
    char *line = NULL;
    size_t cap = 0;
    message m;
    memset(&m, 0, sizeof m);
    const char *brk = getenv("EXAMPLE_SLAM_BREAK");
    const char *kill = getenv("EXAMPLE_SLAM_KILL_AT_STEP");
    int broken_estimate = brk && !strcmp(brk, "estimate");
    int broken_trajectory = brk && !strcmp(brk, "trajectory");
    long kill_at = kill ? strtol(kill, NULL, 10) : -1;
    fprintf(stderr, "example_slam: dead reckoning with landmark averaging, protocol %d\n", PROTOCOL);
    while (getline(&line, &cap, stdin) != -1) {
        size_t n = strlen(line);
        while (n && (line[n - 1] == '\n' || line[n - 1] == '\r')) line[--n] = '\0';
        if (!n) continue;
        if (!read_message(line, &m)) {
            reply_error("malformed JSON message");
        } else {
            handle(&m, broken_estimate, broken_trajectory, kill_at);
        }
        fflush(stdout);
    }
    return 0;
}
