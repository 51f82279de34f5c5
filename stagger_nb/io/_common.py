"""What every file format shares, in one place to import from: the one input policy (:mod:`._input`:
:func:`read_regular_file`, what may be read, and how), the one output policy (:mod:`._output`:
:func:`atomic_write_bytes`; :mod:`._confined`: :func:`write_confined` for a folder the package owns, such as a
batch's OUT), the error base class and text decoding (:mod:`._text`). Checked numbers are in :mod:`._values`,
the euler -> quaternion conversion in :mod:`stagger_nb.core.rotations` (all re-exported here)."""
from __future__ import annotations

# the readers' value checks live in ._values, the euler conversion in core (one definition); re-exported here,
# where readers import them
from ..core.rotations import _EULER_BLOCK, euler_components, quarter_tan  # noqa: F401
from ..core.rotations import euler_to_quat as euler_deg_to_quat
from ._confined import confined_parts, overwrite_in_place, read_confined, write_confined
from ._input import MAX_INPUT_BYTES, file_path, read_file_head, read_regular_file, sha256_regular_file
from ._output import WriteError, atomic_write_bytes
from ._text import UTF8_BOM, FormatError, decode, read_bytes, read_text  # noqa: F401
from ._values import MAX_TOKEN, finite_number, split_values  # noqa: F401

__all__ = ["atomic_write_bytes", "write_confined", "read_confined", "overwrite_in_place", "confined_parts",
           "WriteError", "FormatError", "read_text", "read_bytes", "decode", "finite_number", "euler_deg_to_quat",
           "MAX_INPUT_BYTES", "read_regular_file", "read_file_head", "sha256_regular_file", "file_path"]
