/*
 * Exact executed-instruction counts for the Cortex-M4F images under QEMU (scripts/m4-counts).
 *
 * A TCG plugin for QEMU's plugin API version 1 (QEMU 4.2 to 8.x, e.g. Debian bookworm's 7.2,
 * whose qemu-system-arm accepts -plugin but ships no plugins and no header): every translated
 * instruction gets an inline "add 1" on a global counter, so the count is exact (conditional
 * instructions of IT blocks count as executed, as the core issues them). Arguments:
 *
 *   mark=0xADDR   the address of the image's marker function (Thumb bit cleared): each time
 *                 its first instruction executes, the running count is recorded;
 *   funcs=FILE    optional: the output of `llvm-nm --print-size --defined-only [-C] ELF`
 *                 ("ADDRESS SIZE TYPE NAME", hex); the count is also split by function
 *                 (text symbols, Thumb bit cleared; of aliases at one address the first is
 *                 kept), a flat profile: each instruction counts for the function holding it;
 *   profile=A:B   with funcs: profile only between marks A and B (0-based; default: the whole
 *                 run).
 *
 * At exit it prints "total N", then "mark K N" for every recorded mark (N: instructions
 * executed before the marker's first instruction), then "func N NAME" for every function with
 * a non-zero count, to QEMU's log (stderr unless -D is given).
 *
 * Build: gcc -shared -fPIC -O2 -o insn_count.so insn_count.c
 */
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The few declarations of QEMU's plugin API (include/qemu/qemu-plugin.h, version 1) used here. */
typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t qemu_info_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int vcpu_index, void *userdata);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void *userdata);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn *insn,
                                            qemu_plugin_vcpu_udata_cb_t cb,
                                            enum qemu_plugin_cb_flags flags, void *userdata);
void qemu_plugin_register_vcpu_insn_exec_inline(struct qemu_plugin_insn *insn,
                                                enum qemu_plugin_op op, void *ptr, uint64_t imm);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *tb, size_t idx);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *insn);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void *userdata);
void qemu_plugin_outs(const char *string);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

static uint64_t total;
static uint64_t mark_addr = UINT64_MAX;
#define MAX_MARKS 65536
static uint64_t marks[MAX_MARKS];
static size_t n_marks;

struct func {
    uint64_t start, end, count, at_a, at_b;
    char *name;
};
static long profile_a = -1, profile_b = -1;
static struct func *funcs;
static size_t n_funcs;

static void on_mark(unsigned int vcpu, void *userdata)
{
    (void)vcpu;
    (void)userdata;
    if ((long)n_marks == profile_a || (long)n_marks == profile_b) {
        for (size_t f = 0; f < n_funcs; f++) {
            if ((long)n_marks == profile_a) {
                funcs[f].at_a = funcs[f].count;
            } else {
                funcs[f].at_b = funcs[f].count;
            }
        }
    }
    if (n_marks < MAX_MARKS) {
        marks[n_marks++] = total;
    }
}

/* Index of the function holding addr, or n_funcs. */
static size_t func_of(uint64_t addr)
{
    size_t lo = 0, hi = n_funcs;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (funcs[mid].end <= addr) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    return (lo < n_funcs && funcs[lo].start <= addr) ? lo : n_funcs;
}

static void on_translate(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    (void)id;
    size_t n = qemu_plugin_tb_n_insns(tb);
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        uint64_t addr = qemu_plugin_insn_vaddr(insn);
        if (addr == mark_addr) {
            /* Before the add below: the marker's own instruction is not yet counted. */
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_mark, QEMU_PLUGIN_CB_NO_REGS, NULL);
        }
        qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &total, 1);
        if (n_funcs > 0) {
            size_t f = func_of(addr);
            if (f < n_funcs) {
                qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64,
                                                           &funcs[f].count, 1);
            }
        }
    }
}

static void at_exit(qemu_plugin_id_t id, void *userdata)
{
    (void)id;
    (void)userdata;
    char line[96];
    snprintf(line, sizeof line, "total %" PRIu64 "\n", total);
    qemu_plugin_outs(line);
    for (size_t k = 0; k < n_marks; k++) {
        snprintf(line, sizeof line, "mark %zu %" PRIu64 "\n", k, marks[k]);
        qemu_plugin_outs(line);
    }
    for (size_t f = 0; f < n_funcs; f++) {
        uint64_t count = profile_b >= 0 ? funcs[f].at_b - funcs[f].at_a : funcs[f].count;
        if (count > 0) {
            char row[512];
            snprintf(row, sizeof row, "func %" PRIu64 " %s\n", count, funcs[f].name);
            qemu_plugin_outs(row);
        }
    }
}

static int by_start(const void *a, const void *b)
{
    const struct func *x = a, *y = b;
    return (x->start > y->start) - (x->start < y->start);
}

static int read_funcs(const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        return -1;
    }
    size_t cap = 0;
    char line[1024], type;
    uint64_t start, size;
    int at = 0;
    while (fgets(line, sizeof line, f)) {
        if (sscanf(line, "%" SCNx64 " %" SCNx64 " %c %n", &start, &size, &type, &at) != 3
            || (type != 't' && type != 'T') || size == 0) {
            continue;
        }
        /* The name is the rest of the line (demangled names hold spaces). */
        char *name = line + at;
        name[strcspn(name, "\n")] = '\0';
        if (n_funcs == cap) {
            cap = cap ? 2 * cap : 1024;
            funcs = realloc(funcs, cap * sizeof *funcs);
            if (!funcs) {
                fclose(f);
                return -1;
            }
        }
        start &= ~(uint64_t)1;
        funcs[n_funcs] = (struct func){ start, start + size, 0, 0, 0, strdup(name) };
        n_funcs++;
    }
    fclose(f);
    qsort(funcs, n_funcs, sizeof *funcs, by_start);
    /* Drop aliases and overlaps: keep the first function at each address range. */
    size_t kept = 0;
    for (size_t i = 0; i < n_funcs; i++) {
        if (kept == 0 || funcs[i].start >= funcs[kept - 1].end) {
            funcs[kept++] = funcs[i];
        }
    }
    n_funcs = kept;
    return 0;
}

__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id,
                                                               const qemu_info_t *info,
                                                               int argc, char **argv)
{
    (void)info;
    for (int i = 0; i < argc; i++) {
        if (strncmp(argv[i], "mark=", 5) == 0) {
            mark_addr = strtoull(argv[i] + 5, NULL, 0) & ~(uint64_t)1;
        } else if (strncmp(argv[i], "funcs=", 6) == 0) {
            if (read_funcs(argv[i] + 6) != 0) {
                fprintf(stderr, "insn_count: cannot read %s\n", argv[i] + 6);
                return -1;
            }
        } else if (strncmp(argv[i], "profile=", 8) == 0) {
            if (sscanf(argv[i] + 8, "%ld:%ld", &profile_a, &profile_b) != 2 || profile_a < 0
                || profile_b <= profile_a) {
                fprintf(stderr, "insn_count: profile=A:B needs marks 0 <= A < B\n");
                return -1;
            }
        } else {
            fprintf(stderr, "insn_count: unknown argument %s\n", argv[i]);
            return -1;
        }
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_translate);
    qemu_plugin_register_atexit_cb(id, at_exit, NULL);
    return 0;
}
