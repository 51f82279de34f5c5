"""Session files: the JSON session format, the embedded JSON motion format, and the guards on writes.

Every path a session names (its source clip, a warp reference, the session file itself) is read through
:func:`stagger_nb.io._common.read_regular_file`: regular files only, within the package's size limit, so
``/dev/zero`` or a FIFO is refused at once instead of exhausting memory or blocking (issue 13). Writes are
atomic, and never replace a file the session did not write: :func:`check_save_target` refuses the source
clip and any existing file that is not a session JSON; :func:`check_export_target` refuses the source clip.
Session files are JSON, never pickle; nothing in them is evaluated.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.motion import Motion
from ..core.skeleton import Skeleton
from ..io._common import atomic_write_bytes, file_path, read_regular_file
from ..io.bvh import parse_bvh, write_bvh
from .ops.fields import _fail, check_extract_options, integer, number, text, tuple_of

if TYPE_CHECKING:   # the return type of SessionFiles.from_json / load
    from .session import Session

__all__ = ["SESSION_FORMAT", "SESSION_VERSION", "motion_to_json", "motion_from_json", "read_source",
           "read_session_json", "session_bytes", "MAX_SESSION_BYTES", "check_save_target",
           "check_export_target", "same_file", "export_gltf", "SessionFiles"]

SESSION_FORMAT = "stagger_nb.session"
SESSION_VERSION = 1


# --------------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------------
def read_source(path: str, field: str = "source.path") -> tuple[Motion, str]:
    """``(motion, sha256 hex)`` of the BVH file ``path``, read once (regular file, size limit); errors are
    ValueErrors starting with ``field``."""
    try:
        raw = read_regular_file(path, what="BVH file")
    except ValueError as e:
        raise ValueError(f"{field}: {e}") from None
    digest = hashlib.sha256(raw).hexdigest()
    try:
        return parse_bvh(raw, os.fspath(path)), digest
    except ValueError as e:  # BVHError: names the file and line
        raise ValueError(f"{field}: {e}") from None


#: Largest session file read or written. Parsing JSON of floats costs ~8x its size (a 60 MB file of arrays
#: peaked at 530 MB RSS), so this keeps a hostile file near 300 MB; ops take kilobytes, and an embedded
#: CMU 01_01 (2,751 frames) ~7 MB (longer takes are saved by their source path).
MAX_SESSION_BYTES = 32 << 20


def session_bytes(data: Any) -> bytes:
    """The UTF-8 JSON text of a session dict (no NaN), refused over :data:`MAX_SESSION_BYTES`."""
    raw = json.dumps(data, indent=1, allow_nan=False).encode("utf-8")
    if len(raw) > MAX_SESSION_BYTES:
        raise ValueError(f"session: {len(raw):,} bytes of JSON is over the {MAX_SESSION_BYTES:,}-byte limit of "
                         "a session file: save a long take by its source path (embed_source=False)")
    return raw


def read_session_json(path) -> Any:
    """The parsed JSON of a session file (regular file within :data:`MAX_SESSION_BYTES`; no NaN/Infinity;
    UTF-8; a JSON object whose ``format`` is :data:`SESSION_FORMAT`, else a ValueError that names the file
    without quoting it)."""
    try:
        raw = read_regular_file(path, what="session file", max_bytes=MAX_SESSION_BYTES)
    except ValueError as e:
        raise ValueError(f"session: {e}") from None
    try:
        text_ = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ValueError(f"session: {path} is not UTF-8 JSON text (byte {e.start})") from None
    del raw  # the text alone while parsing

    def no_constants(c):
        raise ValueError(f"session: {c} is not allowed in a session file")

    try:
        data = json.loads(text_, parse_constant=no_constants)
    except json.JSONDecodeError as e:
        raise ValueError(f"session: {path} is not valid JSON ({e})") from None
    except ValueError as e:  # an integer of more than 4,300 digits (int()'s limit); NaN is said above
        raise ValueError(str(e) if str(e).startswith("session:") else f"session: {path}: {e}") from None
    except RecursionError:
        raise ValueError(f"session: {path} nests JSON too deeply for a session file") from None
    if not (isinstance(data, dict) and data.get("format") == SESSION_FORMAT):  # its content is not quoted
        raise ValueError(f"format: {path} is not a stagger_nb session file (no \"format\": \"{SESSION_FORMAT}\"; "
                         "its content is not quoted)")
    return data


# --------------------------------------------------------------------------------------------------
# write guards
# --------------------------------------------------------------------------------------------------
def same_file(a, b) -> bool:
    """True when paths ``a`` and ``b`` name the same existing file (symlinks and hard links included)."""
    try:
        return os.path.realpath(a) == os.path.realpath(b) or os.path.samefile(a, b)
    except OSError:
        return False


def check_export_target(path, source_path) -> None:
    """Refuse to replace the session's source clip."""
    if source_path is not None and os.path.exists(path) and same_file(path, source_path):
        raise ValueError(f"path: {path} is the session's source file; export to another file")


def export_gltf(motion: Motion, path, source_path, units="auto") -> None:
    """Write ``motion`` as glTF 2.0 (``.glb``/``.gltf``, atomically, lengths in metres; see
    :func:`stagger_nb.io.gltf.write_gltf`), refusing to replace the source clip."""
    from ..io.gltf import write_gltf
    path = file_path(path, "path")
    check_export_target(path, source_path)
    write_gltf(motion, path, units=units)


def check_save_target(path, source_path) -> None:
    """Refuse to replace the source clip, or any existing file that is not a session JSON (a BVH, a
    notebook, a device): saving writes a session only where a session (or nothing) was."""
    check_export_target(path, source_path)
    if not os.path.lexists(path):
        return
    try:
        data = read_session_json(path)
    except ValueError:
        data = None
    if not (isinstance(data, dict) and data.get("format") == SESSION_FORMAT):
        raise ValueError(f"path: {path} exists and is not a stagger_nb session file; save to a new file "
                         "or remove it first")


# --------------------------------------------------------------------------------------------------
# the embedded motion format (sessions without a source file)
# --------------------------------------------------------------------------------------------------
def motion_to_json(m: Motion) -> dict:
    """A JSON-ready dict of ``m`` (skeleton, frame time, root positions (F, 3), local quaternions
    (F, J, 4) x, y, z, w, optional local translations (F, J, 3))."""
    sk = m.skeleton
    return {"names": list(sk.names), "parents": sk.parents.tolist(), "offsets": sk.offsets.tolist(),
            "channels": [list(c) for c in sk.channels],
            "end_sites": {str(k): v.tolist() for k, v in sk.end_sites.items()},
            "frame_time": m.frame_time, "root_positions": m.root_positions.tolist(),
            "local_quats": m.local_quats.tolist(),
            "local_translations": None if m.local_translations is None else m.local_translations.tolist()}


_MOTION_FIELDS = ("names", "parents", "offsets", "channels", "end_sites", "frame_time", "root_positions",
                  "local_quats", "local_translations")
_CHANNEL_RE = re.compile(r"[XYZ](position|rotation)\Z", re.IGNORECASE)


def _float_array(value, field, shape_tail: tuple) -> np.ndarray:
    """``value`` (nested JSON lists of numbers) as a float array of shape ``(N,) + shape_tail``."""
    try:
        a = np.asarray(value)
    except ValueError:  # ragged nesting
        a = None
    if a is None or a.dtype.kind not in "iuf" or a.ndim != 1 + len(shape_tail) or a.shape[1:] != shape_tail:
        _fail(field, f"an array of numbers of shape (N, {', '.join(map(str, shape_tail))})",
              type(value).__name__ if a is None or a.size > 8 else value)
    a = a.astype(float)
    if not np.all(np.isfinite(a)):
        _fail(field, "finite numbers", "a non-finite value")
    return a


def motion_from_json(d: Any, field: str) -> Motion:
    """The Motion of :func:`motion_to_json`'s dict, every field checked (ValueError names ``field.key``)."""
    if not isinstance(d, dict):
        _fail(field, "an embedded motion object", d)
    for k in d:
        if k not in _MOTION_FIELDS:
            raise ValueError(f"{field}.{k}: unknown field of an embedded motion")
    for k in _MOTION_FIELDS[:-1]:
        if k not in d:
            raise ValueError(f"{field}.{k}: missing")
    names = tuple_of(text, "a list of joint names")(d["names"], f"{field}.names")
    J = len(names)
    parents = d["parents"]
    if not isinstance(parents, list) or len(parents) != J:
        _fail(f"{field}.parents", f"a list of {J} parent indices", parents)
    parents = np.array(tuple_of(integer(-1), "parent indices")(parents, f"{field}.parents"), dtype=np.int64)
    channels = d["channels"]
    if not isinstance(channels, list) or len(channels) != J:
        _fail(f"{field}.channels", f"a list of {J} channel lists", channels)
    for i, c in enumerate(channels):
        if not isinstance(c, list) or not all(isinstance(x, str) and _CHANNEL_RE.match(x) for x in c):
            _fail(f"{field}.channels[{i}]", 'a list like ["Zrotation", "Xrotation", "Yrotation"]', c)
    ends = d["end_sites"]
    if not isinstance(ends, dict):
        _fail(f"{field}.end_sites", "an object {joint index: [x, y, z]}", ends)
    end_sites = {}
    for k, v in ends.items():
        if not (isinstance(k, str) and k.isdigit() and k.isascii() and int(k) < J):
            _fail(f"{field}.end_sites", f"joint indices below {J} as keys", k)
        end_sites[int(k)] = _float_array([v], f"{field}.end_sites.{k}", (3,))[0]
    frame_time = number(0.0, open_lo=True)(d["frame_time"], f"{field}.frame_time")
    offsets = _float_array(d["offsets"], f"{field}.offsets", (3,))
    root = _float_array(d["root_positions"], f"{field}.root_positions", (3,))
    q = _float_array(d["local_quats"], f"{field}.local_quats", (J, 4))
    norms = np.linalg.norm(q, axis=-1) if q.size else np.ones(1)
    if not (np.all(norms > 1e-6) and np.all(np.isfinite(norms))):  # Motion would make a zero one identity
        _fail(f"{field}.local_quats", "non-zero quaternions of finite length", "a zero or overflowing quaternion")
    lt = d.get("local_translations")
    lt = None if lt is None else _float_array(lt, f"{field}.local_translations", (J, 3))
    try:
        sk = Skeleton(names, parents, offsets, tuple(tuple(c) for c in channels), end_sites)
        m = Motion(sk, frame_time, root, q, lt)
    except ValueError as e:  # shapes that disagree, a parent after its child: the message names them
        raise ValueError(f"{field}: {e}") from None
    # Motion() re-normalises the quaternions; the stored ones were already normalised by a Motion, so
    # keep the stored bits exactly (re-normalising can flip the last bit) -> bit-for-bit replay.
    if q.shape == m.local_quats.shape and np.allclose(q, m.local_quats, rtol=0, atol=1e-12):
        q = q.copy()
        q.setflags(write=False)
        object.__setattr__(m, "local_quats", q)
    return m


# --------------------------------------------------------------------------------------------------
# the Session's own file methods
# --------------------------------------------------------------------------------------------------
class SessionFiles:
    """What a :class:`~stagger_nb.session.Session` writes and reads: its JSON (source by path + SHA-256, or
    embedded), save / load, and the exports of the edited motion. A mixin of the Session (it reads ``source``,
    ``source_path``, ``extract_options``, ``ops`` and ``edited()``)."""

    def to_json(self, embed_source: bool | None = None) -> dict:
        """The session as a JSON-ready dict. The source is referenced by path (+ SHA-256) when the
        session has one, otherwise embedded (``embed_source=True`` forces embedding)."""
        if embed_source is None:
            embed_source = self.source_path is None
        if embed_source:
            source = {"motion": motion_to_json(self.source)}
        else:
            if self.source_path is None:
                raise ValueError("embed_source: False needs a session with a source_path")
            raw = read_regular_file(self.source_path, what="source file")
            source = {"path": self.source_path, "sha256": hashlib.sha256(raw).hexdigest()}
        return {"format": SESSION_FORMAT, "version": SESSION_VERSION, "source": source,
                "extract_options": json.loads(json.dumps(self.extract_options)), "ops": self.ops}

    def save(self, path, embed_source: bool | None = None) -> None:
        """Write the session as JSON, atomically (temporary file + rename). Refuses to replace the source
        clip or any existing file that is not a session file."""
        path = file_path(path, "path")
        check_save_target(path, self.source_path)
        atomic_write_bytes(path, session_bytes(self.to_json(embed_source)))  # refused over the size limit

    @classmethod
    def from_json(cls, data: Any, source: Motion | None = None) -> Session:
        """Validate ``data`` (a parsed session file) and build the session. ``source`` overrides the
        stored source (for a moved file)."""
        if not isinstance(data, dict):
            _fail("session", "a JSON object", data)
        for k in data:
            if k not in ("format", "version", "source", "extract_options", "ops"):
                raise ValueError(f"{k}: unknown field in a session file")
        if data.get("format") != SESSION_FORMAT:
            _fail("format", repr(SESSION_FORMAT), data.get("format"))
        if type(data.get("version")) is not int or data.get("version") != SESSION_VERSION:  # true == 1
            _fail("version", str(SESSION_VERSION), data.get("version"))
        opts = check_extract_options(data.get("extract_options", {}))
        ops = cls._typed_list(data.get("ops"), "ops")
        src = data.get("source")
        path = None
        if source is None:
            if not isinstance(src, dict):
                _fail("source", '{"path": ..., "sha256": ...} or {"motion": {...}}', src)
            if "path" in src and "motion" in src:
                raise ValueError("source: give either path or motion, not both")
            if "path" in src:
                path = text(src["path"], "source.path")
                source, digest = read_source(path, "source.path")
                want = src.get("sha256")
                if want is not None and text(want, "source.sha256") != digest:
                    raise ValueError(f"source.sha256: {path} changed since the session was saved")
            elif "motion" in src:
                source = motion_from_json(src["motion"], "source.motion")
            else:
                _fail("source", '{"path": ...} or {"motion": {...}}', src)
        elif isinstance(src, dict) and "path" in src:
            path = src["path"] if isinstance(src["path"], str) else None
        return cls(source, ops, source_path=path, extract_options=opts)

    @classmethod
    def load(cls, path, source: Motion | None = None) -> Session:
        """Read a session file written by :meth:`save` (validated; ValueError names the bad field)."""
        return cls.from_json(read_session_json(path), source=source)

    def export_bvh(self, path) -> None:
        """Write the edited motion as BVH, atomically; refuses to overwrite the source file."""
        path = file_path(path, "path")
        check_export_target(path, self.source_path)
        write_bvh(self.edited(), path)

    def export_gltf(self, path, units="auto") -> None:
        """Write the edited motion as glTF 2.0 (``.glb`` or ``.gltf``: a skinned skeleton and one animation,
        metres; :func:`stagger_nb.io.gltf.write_gltf`), atomically; refuses to overwrite the source file."""
        export_gltf(self.edited(), path, self.source_path, units)
