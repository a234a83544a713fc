"""data_loaders: readers (and writers) of measured BRDF formats, returning ``MeasuredBRDF``.

``load(path)`` picks the reader from the file's content, not only its name:

===========================  ===============================================
content                      reader
===========================  ===============================================
starts ``b"tensor_file\\0"``   RGL-EPFL / Mitsuba tensor file (``read_rgl``):
                             ``rgb`` (``*_rgb.bsdf``) or ``spectra`` +
                             ``wavelengths`` (``*_spec.bsdf``, converted to
                             linear sRGB under D65: docs/colour.md)
int32 header (90, 90, 180)   MERL ``.binary`` (``read_merl``; any other size
                             is reported as truncated/padded)
exactly 1,990,656 bytes      UTIA ``.bin`` (``read_utia``), unless it starts
                             like a PNG, gzip, .npy... (refused) or a zip
                             (the NPZ reader)
zip magic ``PK\\x03\\x04``     NPZ sample list (``read_npz``)
UTF-8 text                   CSV sample list (``read_csv``)
===========================  ===============================================

Failing those, a ``.binary`` / ``.bin`` / ``.bsdf`` name sends the file to that
format's reader, which then says what is wrong. Every problem with a file
raises :class:`MeasuredDataError` naming the file and the problem (sizes are
checked against the file and caps before anything is allocated; no pickles);
implausible but readable content gives a :class:`MeasuredDataWarning`.
Loaders know nothing of models.
"""

import os

from .errors import MeasuredDataError, MeasuredDataWarning, looks_like, open_regular, require_file, warn_data
from .measured import CHANNEL_NAMES, MeasuredBRDF, Provenance, plausibility_problems
from .pairs import DirectionsFileError, read_directions
from .merl import (MERL_FILE_SIZE, MerlTable, half_diff_to_std, merl_index, read_merl,
                   std_to_half_diff, write_merl)
from .rgl import RglTable, read_rgl, read_tensor_file, write_tensor_file
from .samples import SampleListTable, read_csv, read_npz, write_samples
from .utia import UTIA_FILE_SIZE, UtiaTable, read_utia, utia_index, write_utia

__all__ = [
    "CHANNEL_NAMES", "MeasuredBRDF", "MeasuredDataError", "MeasuredDataWarning", "Provenance",
    "detect_format", "load",
    "MerlTable", "read_merl", "write_merl", "merl_index", "std_to_half_diff", "half_diff_to_std",
    "UtiaTable", "read_utia", "write_utia", "utia_index",
    "RglTable", "read_rgl", "read_tensor_file", "write_tensor_file",
    "SampleListTable", "read_csv", "read_npz", "write_samples",
    "DirectionsFileError", "read_directions",
]

_READERS = {"merl": read_merl, "utia": read_utia, "rgl": read_rgl, "npz": read_npz, "csv": read_csv}
_SUFFIXES = {".binary": "merl", ".bin": "utia", ".bsdf": "rgl", ".npz": "npz", ".csv": "csv"}


def detect_format(path: str | os.PathLike[str]) -> str:
    """The format name of a file ("merl", "utia", "rgl", "npz", "csv") from its content
    ("rgl" for RGB and spectral tensor files alike: ``read_rgl`` tells them apart).

    Raises MeasuredDataError for a missing, empty or unrecognised file.
    """
    path = require_file(path)
    try:
        size = os.path.getsize(path)
        with open_regular(path) as f:
            head = f.read(4096)
    except OSError as e:
        raise MeasuredDataError(path, f"cannot read the file ({e.strerror or e})") from None
    if size == 0:
        raise MeasuredDataError(path, "empty file (0 bytes)")
    if head.startswith(b"tensor_file\0"):
        return "rgl"
    if len(head) >= 12 and head[:12] == (90).to_bytes(4, "little") + (90).to_bytes(4, "little") \
            + (180).to_bytes(4, "little"):
        return "merl"
    if size == UTIA_FILE_SIZE:
        looks = looks_like(head)
        if looks == "a zip / .npz archive":
            return "npz"            # the content decides; the NPZ reader says what is wrong
        if looks is not None:
            raise MeasuredDataError(path, f"has the size of a UTIA .bin ({UTIA_FILE_SIZE:,} bytes) but "
                                          f"starts like {looks}, not like a table of numbers")
        return "utia"
    if head.startswith(b"PK\x03\x04"):
        return "npz"
    suffix = os.path.splitext(path)[1].lower()
    if suffix in (".binary", ".bin", ".bsdf"):
        return _SUFFIXES[suffix]      # the reader reports what is wrong
    if b"\0" not in head:
        try:
            head.decode("utf-8")
            return "csv"
        except UnicodeDecodeError as e:
            if e.start >= len(head) - 3:   # a multi-byte character cut at 4096
                return "csv"
    raise MeasuredDataError(
        path, f"unrecognised file ({size:,} bytes): not a MERL .binary ({MERL_FILE_SIZE:,} bytes, "
              f"header 90 90 180), UTIA .bin ({UTIA_FILE_SIZE:,} bytes), RGL tensor file, "
              "NPZ or CSV sample list")


def load(path: str | os.PathLike[str], **options: object) -> MeasuredBRDF:
    """Load a measured BRDF file of any supported format into a MeasuredBRDF.

    ``options`` go to the chosen reader (e.g. ``units="dj_brdf"`` for UTIA,
    ``grid=(64, 64, 128)`` for RGL, ``units="degrees"`` for a sample list
    without a units header).

    Valid-looking but implausible content (all values zero, values far above
    any measured BRDF: ``measured.plausibility_problems``) is returned all the
    same, with a :class:`MeasuredDataWarning` naming the file.
    """
    measured = _READERS[detect_format(path)](path, **options)
    for problem in plausibility_problems(measured):
        warn_data(path, problem, stacklevel=2)
    return measured
