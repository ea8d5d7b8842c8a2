"""Shell completion: the scripts for bash, zsh and fish, and what they complete."""

from __future__ import annotations

import shutil
import subprocess

import pytest
from conftest import enc_exe, run

from enctools.data.rig import bundled_rigs


def complete(words: str, cword: int) -> list[tuple[str, str]]:
    """What bash completion offers for the word at ``cword`` of ``words``: (type, value)."""
    r = run([enc_exe()], env={"COMP_WORDS": words, "COMP_CWORD": str(cword),
                              "_ENC_COMPLETE": "bash_complete"})
    assert r.returncode == 0, r.stderr
    return [tuple(line.split(",", 1)) for line in r.stdout.decode().splitlines()]


@pytest.mark.parametrize("shell", ["bash", "zsh", "fish"])
def test_each_shell_gets_a_script(shell):
    r = run([enc_exe()], env={"_ENC_COMPLETE": f"{shell}_source"})
    assert r.returncode == 0, r.stderr
    script = r.stdout.decode()
    assert "_ENC_COMPLETE" in script and f"{shell}_complete" in script
    exe = shutil.which(shell)
    if exe is not None and shell != "fish":  # the script parses in its own shell
        checked = subprocess.run([exe, "-n"], input=r.stdout, capture_output=True, timeout=30)
        assert checked.returncode == 0, checked.stderr.decode()


def test_commands_options_and_rigs_complete():
    assert ("plain", "acquire") in complete("enc acq", 1)
    assert {("plain", "interp-check")} <= set(complete("enc in", 1))
    assert ("plain", "--method") in complete("enc selfcal --me", 2)
    offered = complete("enc acquire --rig ", 3)
    assert [v for t, v in offered if t == "plain"] == bundled_rigs()
    assert ("file", "") in offered  # and any rig file
    assert complete("enc rig check cio", 3)[0] == ("plain", "ciomp-23bit")
