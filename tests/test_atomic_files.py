"""The atomic writer never writes through a link planted where it writes: a run's files are its own."""

import os
import stat
import tempfile

import pytest

from retrofit import atomic
from retrofit.atomic import staged, write_text_atomic


def plant_links(folder, victim, names):
    for name in names:
        (folder / name).symlink_to(victim)


def test_a_link_at_the_old_predictable_temporary_name_is_not_followed(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    work = tmp_path / "work"
    work.mkdir()
    # the name the writer used to take: .<stem>.<pid>.tmp<suffix>
    plant_links(work, victim, [f".report.{os.getpid()}.tmp.json"])
    write_text_atomic(work / "report.json", "new\n")
    assert victim.read_text() == "precious\n"
    assert (work / "report.json").read_text() == "new\n"


def test_links_at_every_name_the_writer_may_draw_are_not_followed(tmp_path, monkeypatch):
    """The writer draws its temporary names at random; here the draw is forced to fall on planted
    links first (every pattern it can make), and it must step over all of them."""
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    work = tmp_path / "work"
    work.mkdir()
    drawn = ["aaaaaaaa", "bbbbbbbb", "cccccccc", "dddddddd"]
    planted = [f".report.{d}.tmp.json" for d in drawn[:3]] + [f".report.{os.getpid()}.tmp.json"]
    plant_links(work, victim, planted)

    def names():
        yield from drawn
        while True:
            yield "zzzzzzzz"
    monkeypatch.setattr(tempfile, "_get_candidate_names", names)
    write_text_atomic(work / "report.json", "new\n")
    assert victim.read_text() == "precious\n"
    assert (work / "report.json").read_text() == "new\n"
    assert all((work / name).is_symlink() for name in planted)          # left alone
    left = sorted(p.name for p in work.iterdir())
    assert left == sorted(planted + ["report.json"])                      # no temporary left


def test_a_link_at_the_target_is_replaced_by_the_file_not_written_through(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    target = tmp_path / "report.json"
    target.symlink_to(victim)
    write_text_atomic(target, "new\n")
    assert victim.read_text() == "precious\n"
    assert not target.is_symlink() and target.read_text() == "new\n"


def test_a_link_planted_in_place_of_the_temporary_file_while_writing_is_refused(tmp_path):
    """Someone who swaps the temporary file for a link before it is renamed: the rename is refused,
    the target keeps its old contents."""
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    target = tmp_path / "report.json"
    target.write_text("old\n")
    with pytest.raises(atomic.OutputError, match="report.json: cannot write the file: .*replaced"):
        with staged(target) as tmp:
            tmp.write_text("half")
            tmp.unlink()
            tmp.symlink_to(victim)
    assert victim.read_text() == "precious\n" and target.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json", "victim.txt"]


def test_the_file_gets_the_usual_permissions_not_the_temporary_files(tmp_path):
    old = os.umask(0o022)
    try:
        write_text_atomic(tmp_path / "a.txt", "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "a.txt").stat().st_mode) == 0o644


def test_an_error_inside_leaves_no_file_and_no_temporary(tmp_path):
    with pytest.raises(RuntimeError):
        with staged(tmp_path / "a.vcd") as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_a_recording_opened_without_staging_is_not_written_through_a_link(tmp_path):
    from retrofit.frames import PortFrames
    from retrofit.machine.config import load_machine
    from retrofit.outputs import open_output
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    (tmp_path / "rec.bin").symlink_to(victim)
    out = open_output(f"parport+record://{tmp_path / 'rec.bin'}?paced=0", load_machine("chivu-lathe"))
    with pytest.raises(atomic.OutputError, match="cannot write the recording .*rec.bin"):
        with out:
            out.write(PortFrames([0], [1], 3))
    assert victim.read_text() == "precious\n"
