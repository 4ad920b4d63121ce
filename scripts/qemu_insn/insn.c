/*
 * A qemu-user TCG plugin that counts the guest instructions a program executes and prints the total
 * to stderr at exit ("qemu-insn: N guest instructions"). Used to compare kernel paths of the aarch64
 * build (NEON against the portable code) where no aarch64 hardware is at hand: a count of executed
 * instructions, not a time (docs/detection.md, "Speed settings on every path").
 *
 * One counter for all vCPUs, incremented inline without atomics: run the program with one worker
 * thread. Declares the few entries of QEMU's plugin API (qemu-plugin.h, API version 1, QEMU 7.2)
 * it uses. Build and run: scripts/qemu_insn/count.sh.
 */
#include <stdint.h>
#include <stddef.h>
#include <stdio.h>
#include <inttypes.h>
typedef uint64_t qemu_plugin_id_t;
struct qemu_plugin_tb;
typedef struct qemu_info_t qemu_info_t;
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*udata_cb_t)(qemu_plugin_id_t id, void *userdata);
extern void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, tb_trans_cb_t cb);
extern size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
extern void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *tb, enum qemu_plugin_op op, void *ptr, uint64_t imm);
extern void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, udata_cb_t cb, void *userdata);
__attribute__((visibility("default"))) int qemu_plugin_version = 1;
static uint64_t count;
static void trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb) {
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &count, qemu_plugin_tb_n_insns(tb));
}
static void done(qemu_plugin_id_t id, void *p) {
    fprintf(stderr, "qemu-insn: %" PRIu64 " guest instructions\n", count);
}
__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv) {
    qemu_plugin_register_vcpu_tb_trans_cb(id, trans);
    qemu_plugin_register_atexit_cb(id, done, NULL);
    return 0;
}
