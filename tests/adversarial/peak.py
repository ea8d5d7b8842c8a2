"""Run a command and report its peak resident memory and CPU, as GNU time does.

    python peak.py FD COMMAND [ARG...]

A process's ``ru_maxrss`` counts the memory it had when it was forked (the kernel
keeps the old image's high-water mark across exec), so a command forked from a large
test process reports that process's size. This small process is forked instead; its
child is forked from it, and wait4 gives the child's own peak [KiB] and CPU [s],
written to file descriptor FD as "maxrss_kib cpu_s". Signals sent to this process
are passed on to the child, and it ends as the child ended (its exit status, or the
same signal).
"""

import os
import signal
import sys

#: every signal a command catches as its ending (enctools.errors.ending_signal_numbers,
#: spelled out: this process runs with ``-I -S``, without enctools on its path)
FORWARDED = (*(getattr(signal, name) for name in (
    "SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT", "SIGUSR1", "SIGUSR2", "SIGALRM", "SIGXCPU",
    "SIGVTALRM", "SIGPROF", "SIGIO", "SIGPWR", "SIGSTKFLT") if hasattr(signal, name)),
    *range(signal.SIGRTMIN, signal.SIGRTMAX + 1))


def main() -> None:
    fd, argv = int(sys.argv[1]), sys.argv[2:]
    pid = os.fork()
    if pid == 0:
        os.close(fd)
        try:
            os.execvp(argv[0], argv)
        finally:
            os._exit(127)
    for sig in FORWARDED:
        signal.signal(sig, lambda s, _frame: os.kill(pid, s))
    _, status, usage = os.wait4(pid, 0)
    os.write(fd, f"{usage.ru_maxrss} {usage.ru_utime + usage.ru_stime}".encode())
    os.close(fd)
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        signal.signal(sig, signal.SIG_DFL)
        os.kill(os.getpid(), sig)
    os._exit(os.waitstatus_to_exitcode(status))


main()
