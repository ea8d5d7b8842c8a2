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
    return [tuple(line.split(",", 1)) for line in r.stdout.decode().splitlines() if line]


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
    assert ("plain", "closure") in complete("enc clo", 1)
    assert ("plain", "closure") in complete("enc acquire --mode c", 3)
    assert ("plain", "--method") in complete("enc selfcal --me", 2)
    offered = complete("enc acquire --rig ", 3)
    assert [v for t, v in offered if t == "plain"] == bundled_rigs()
    assert ("file", "") in offered  # and any rig file
    assert complete("enc rig check cio", 3)[0] == ("plain", "ciomp-23bit")


@pytest.fixture(scope="module")
def dual_run(tmp_path_factory):
    """A one-revolution run of sjtu-dual: heads P1, P2 and H1..H7."""
    path = tmp_path_factory.mktemp("completion") / "run.parquet"
    r = run([enc_exe(), "acquire", "--rig", "sjtu-dual", "--revolutions", "1", "-o", str(path)])
    assert r.returncode == 0, r.stderr
    return path


def plain(offered: list[tuple[str, str]]) -> list[str]:
    return [v for t, v in offered if t == "plain"]


def test_heads_complete_from_the_input_file(dual_run):
    heads = ["P1", "P2", *(f"H{i}" for i in range(1, 8))]
    # INPUT before the option: click cannot parse a line that ends in a bare --device,
    # so the names come from the words of the line
    assert plain(complete(f"enc compare {dual_run} --device ", 4)) == heads
    assert plain(complete(f"enc selfcal --band 3 {dual_run} --ref-head P", 6)) == ["P1", "P2"]
    # in a comma list: the last name, never one already given
    offered = plain(complete(f"enc selfcal {dual_run} --heads H1,H2,H", 4))
    assert offered == [f"H1,H2,H{i}" for i in range(3, 8)]
    # INPUT after the option is not known yet: nothing is guessed
    assert plain(complete(f"enc interp-check --heads  {dual_run}", 3)) == []


def test_heads_complete_from_the_rig():
    assert plain(complete("enc acquire --rig sjtu-dual --heads P", 5)) == ["P1", "P2"]
    r = run([enc_exe()], env={"COMP_WORDS": "enc acquire --heads ", "COMP_CWORD": "3",
                              "_ENC_COMPLETE": "bash_complete", "ENC_RIG": "ciomp-23bit"})
    from enctools.data.rig import load_rig
    assert r.stdout.decode().split() == [f"plain,{h}" for h in load_rig("ciomp-23bit").head_names]


def test_heads_complete_nothing_from_what_is_not_a_stream(tmp_path):
    junk = tmp_path / "notes.txt"
    junk.write_text("not a stream\n")
    for line, cword in ((f"enc selfcal {junk} --ref-head ", 4), ("enc selfcal - --ref-head ", 4),
                        (f"enc selfcal {tmp_path}/missing --ref-head ", 4),
                        ("enc acquire --rig no-such-rig --heads ", 5)):
        assert plain(complete(line, cword)) == [], line


def test_correct_completes_its_table_and_format():
    assert ("plain", "correct") in complete("enc cor", 1)
    assert {("plain", "--table"), ("plain", "--target")} <= set(complete("enc correct --ta", 2))
    assert complete("enc correct --table ", 3) == [("file", "")]
    assert plain(complete("enc correct --target m", 3)) == ["mif", "mem"]
