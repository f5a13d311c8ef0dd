/* LD_PRELOAD shim for Debian bookworm's user-mode-linux (6.1) on hosts with large XSAVE
 * areas (AVX-512, AMX).
 *
 * Why: UML saves a guest process's FPU state with PTRACE_GETREGSET(NT_X86_XSTATE) into a
 * buffer sized for x87/SSE/AVX only (struct _xstate, 832 bytes) and restores it with
 * PTRACE_SETREGSET. The host kernel truncates the GET quietly but refuses a SET whose size
 * is not its full XSAVE size (EFAULT), so on such a host every guest process dies at once:
 * "userspace - ptrace set fp regs failed, errno = 14", then "Attempted to kill init!".
 *
 * Fix: a short SETREGSET is widened to the host's size. The components UML did not save
 * (AVX-512, AMX, PKRU) are taken from the tracee's current state, so the x87/SSE/AVX part
 * is exactly UML's and nothing else changes. Guest code must therefore not rely on
 * AVX-512 registers surviving a switch between threads of one process; run_in_vcan.sh sets
 * GLIBC_TUNABLES in the guest so glibc's string functions do not use them.
 *
 * Only the UML process loads this (run_in_vcan.sh sets LD_PRELOAD for linux.uml alone).
 * UML calls ptrace from its single kernel thread, so one static buffer suffices. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <elf.h>
#include <stdarg.h>
#include <string.h>
#include <sys/ptrace.h>
#include <sys/types.h>
#include <sys/uio.h>

typedef long (*ptrace_fn)(enum __ptrace_request, pid_t, void*, void*);

/* Larger than any x86 XSAVE area to date (AMX: about 11 KiB). */
static unsigned char full_state[64 * 1024] __attribute__((aligned(64)));

long ptrace(enum __ptrace_request request, ...) {
  static ptrace_fn real_ptrace;
  va_list ap;
  va_start(ap, request);
  pid_t pid = va_arg(ap, pid_t);
  void* addr = va_arg(ap, void*);
  void* data = va_arg(ap, void*);
  va_end(ap);
  if (real_ptrace == NULL) {
    real_ptrace = (ptrace_fn)dlsym(RTLD_NEXT, "ptrace");
  }
  if (request == PTRACE_SETREGSET && (unsigned long)addr == NT_X86_XSTATE && data != NULL) {
    const struct iovec* in = (const struct iovec*)data;
    struct iovec io = {full_state, sizeof(full_state)};
    if (real_ptrace(PTRACE_GETREGSET, pid, addr, &io) == 0 && io.iov_len > in->iov_len) {
      memcpy(full_state, in->iov_base, in->iov_len);
      return real_ptrace(PTRACE_SETREGSET, pid, addr, &io);
    }
  }
  return real_ptrace(request, pid, addr, data);
}
