"""Every signal whose default action ends a process (signal(7)) and that reaches it from
outside is caught as the command's ending (errors.ending_signals): its outputs whole or
not at all, 128 + its number. Before, SIGXCPU (ulimit -t), the timers' signals, SIGIO,
SIGPWR, SIGSTKFLT and the real-time signals killed a command where it stood: a recording
left as its temporary, an output's temporary left behind. The catalogue's rows
(signals.toml, signals-outputs.toml, nightly.toml) run them through the commands."""

from __future__ import annotations

import signal

from enctools.errors import Interrupted, ending_signal_numbers, ending_signals, signal_name

#: default action: continue, stop, or nothing (signal(7))
NOT_ENDING = {"SIGCHLD", "SIGCONT", "SIGSTOP", "SIGTSTP", "SIGTTIN", "SIGTTOU", "SIGURG",
              "SIGWINCH"}
#: cannot be caught; or a fault of the process itself, whose state is not to be trusted
NOT_CAUGHT = {"SIGKILL", "SIGSEGV", "SIGBUS", "SIGILL", "SIGFPE", "SIGABRT", "SIGSYS",
              "SIGTRAP"}
#: ignored by Python at its start: EPIPE and EFBIG are met instead
IGNORED = {"SIGPIPE", "SIGXFSZ"}


def test_every_ending_signal_is_caught():
    left = {signal_name(s) for s in signal.valid_signals()} - NOT_ENDING - NOT_CAUGHT - IGNORED
    assert left == {signal_name(s) for s in ending_signal_numbers()}
    assert len(ending_signal_numbers()) == len(set(ending_signal_numbers()))


def test_a_real_time_signal_is_named_and_its_status_is_128_plus_its_number():
    n = signal.SIGRTMIN + 3
    e = Interrupted.by_signal(n)
    assert str(e) == "stopped by SIGRTMIN+3" and e.exit_code == 128 + n
    assert str(Interrupted.by_signal(signal.SIGXCPU)) == "stopped by SIGXCPU"
    assert Interrupted.by_signal(signal.SIGTERM).exit_code == 143


def test_an_ignored_one_stays_ignored():
    old = signal.signal(signal.SIGPWR, signal.SIG_IGN)
    try:
        assert signal.SIGPWR not in ending_signals()
        assert signal.SIGPWR in ending_signal_numbers()
    finally:
        signal.signal(signal.SIGPWR, old)
