"""The output folder of a batch: input lists, result file names, and the folder as a fit sees it."""

import dataclasses
import hashlib
import os
import pathlib
from collections.abc import Iterable

from brdf import __version__
from brdf_fit.errors import printable  # noqa: F401 -- batch modules import it from here
from fitting.file_names import safe_stem
from fitting.result import FitResult, ResultFileError, atomic_write_text
from fitting.result_file import read_text

MEASURED_SUFFIXES = (".binary", ".bin", ".bsdf", ".npz", ".csv")
#: The output folder's record of which input each unsuffixed material name belongs to
#: (``ResultFolder.claim``): a hidden folder of one small file per name, holding a sha256.
CLAIMS = ".names"


def expand_inputs(items: Iterable[str | os.PathLike[str]],
                  exclude: Iterable[str | os.PathLike[str]] = ()) -> list[pathlib.Path]:
    """Files and folders -> sorted list of files (folders: their entries with a
    measured-data suffix), without the files ``exclude`` names (a batch's own
    summary.csv, when it writes into a folder of its inputs).  A folder's entry named
    like a measurement that is no regular file (a FIFO, a dangling link, a link loop,
    a folder) is listed too: the loader refuses it in one line, an error row of the
    summary, as it does a file named on the command line, instead of its being
    passed over without a word."""
    excluded = [e for e in exclude if os.path.lexists(e)]
    files = []
    for item in items:
        p = pathlib.Path(item)
        if p.is_dir():
            files.extend(sorted(q for q in p.iterdir() if q.suffix.lower() in MEASURED_SUFFIXES))
        else:
            files.append(p)
    return [f for f in files if not any(_same_file(f, e) for e in excluded)]


def _same_file(a, b):
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def result_name(material: str, model: str) -> str:
    """The file name of a result: ``MATERIAL.MODEL.json``."""
    return f"{material}.{model}.json"


def result_path(out_dir: str | os.PathLike[str], material: str, model: str) -> pathlib.Path:
    """Where the result of ``model`` on ``material`` lives in ``out_dir``."""
    return pathlib.Path(out_dir) / result_name(material, model)


def _path_key(path):
    """A short, stable name suffix for an input path (two inputs with one base name)."""
    return hashlib.sha256(os.fsencode(os.path.abspath(path))).hexdigest()[:8]


def colliding_names(files: Iterable[str | os.PathLike[str]]) -> set[str]:
    """The files of a batch whose base names (hence material names) collide."""
    seen = {}
    for f in files:
        seen.setdefault(pathlib.Path(f).stem.lower(), []).append(str(f))
    return {f for group in seen.values() if len(group) > 1 for f in group}


# --- the output folder as one file's fit sees it -----------------------------------------

class ResultFolder:
    """The output folder on disk (a local run, or Dask workers on a shared filesystem)."""

    def __init__(self, out_dir: str | os.PathLike[str]) -> None:
        self.out_dir = pathlib.Path(out_dir)

    def exists(self, name: str) -> bool:
        """Whether a file ``name`` is in the folder."""
        return (self.out_dir / name).exists()

    def load(self, name: str) -> FitResult | None:
        """The valid result ``name``, or None (absent or not a readable result)."""
        return load_quietly(self.out_dir / name)

    def save(self, name: str, result: FitResult) -> None:
        """Write ``result`` as ``name``, atomically."""
        result.save(self.out_dir / name)

    def claim(self, material: str, sha256: str, path: str | os.PathLike[str]) -> bool:
        """Claim the unsuffixed result name ``material`` for the input file ``path`` whose
        content has ``sha256``, once for the folder: True when it is that input's (claimed
        now, or before by the same content or the same file, edited since), False when
        another input's.  Without it two workers fitting two files of one material name at
        once each found no results under the name and both wrote MATERIAL.MODEL.json, one
        input's results lost (seen under load: two 'steel' files of
        tests/test_library_names.py).  The claim is a file created exclusively (O_EXCL), so
        it holds across processes and Dask workers sharing the folder; where it cannot be
        written (a read-only or full disk), the name is taken as before (True)."""
        claim = self.out_dir / CLAIMS / material
        mine = f"{sha256}\n{os.path.abspath(path)}\n"
        try:
            claim.parent.mkdir(exist_ok=True)
            fd = os.open(claim, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                held = claim.read_text(encoding="utf-8", errors="surrogateescape").splitlines()
            except OSError:
                return False        # unreadable: another's
            if held[:1] == [sha256]:
                return True
            if held[1:2] == [os.path.abspath(path)]:        # the same file, edited: its name still
                atomic_write_text(claim, mine)
                return True
            return False            # another input's (or being written by the one that created it)
        except OSError:
            return True
        try:
            with os.fdopen(fd, "w", encoding="utf-8", errors="surrogateescape") as f:
                f.write(mine)
        except OSError:             # a full disk: no claim; the result's own write says so, naming the folder
            claim.unlink(missing_ok=True)
        return True

    def load_text(self, name: str) -> str | None:
        """The text of the small file ``name`` (a screening record), or None: absent,
        unreadable, not UTF-8, or larger than a result file may be (MAX_RESULT_BYTES)."""
        try:
            return read_text(self.out_dir / name)
        except ResultFileError:
            return None

    def save_text(self, name: str, text: str) -> None:
        """Write ``text`` as ``name``, atomically (OSError if it cannot be written)."""
        atomic_write_text(self.out_dir / name, text)


class ResultSnapshot(ResultFolder):
    """The output folder as it was when the batch began (a Dask worker that has no
    access to it: ``--send-data``).  Saved results and texts are kept in ``written``
    ({name: text, exactly what FitResult.save or save_text writes}) for the client to
    write.  It holds the results only: the screening records from before the batch
    are not sent, so ``load_text`` finds none of them and such an input is screened
    again (correct, a few seconds slower than a run by path)."""

    def __init__(self, results: dict[str, FitResult]) -> None:
        self.results = dict(results)
        self.written: dict[str, str] = {}
        self.claims: dict[str, tuple[str, str]] = {}     # material: (sha256, absolute path)

    def exists(self, name: str) -> bool:
        """Whether ``name`` was in the folder (or was saved here since)."""
        return name in self.results or name in self.written

    def load(self, name: str) -> FitResult | None:
        """The result ``name`` of the snapshot, or None."""
        return self.results.get(name)

    def save(self, name: str, result: FitResult) -> None:
        """Keep ``result``'s JSON text for the client (validated as FitResult.save does)."""
        self.written[name] = result.to_json() + "\n"

    def claim(self, material: str, sha256: str, path: str | os.PathLike[str]) -> bool:
        """``ResultFolder.claim`` within this snapshot (one input's fit: its own names)."""
        held = self.claims.setdefault(material, (sha256, os.path.abspath(path)))
        return held[0] == sha256 or held[1] == os.path.abspath(path)

    def load_text(self, name: str) -> str | None:
        """The text saved as ``name`` since the batch began, or None (see the class)."""
        return self.written.get(name)

    def save_text(self, name: str, text: str) -> None:
        """Keep ``text`` for the client to write as ``name``."""
        self.written[name] = text


def material_name(folder, measured, path, models, collides):
    """The material part of the result file names of one input.

    Normally the material's name made safe (``fitting.file_names.safe_stem``:
    it comes from the file); ``NAME-<8 hex of the input's sha256>`` when
    another input of the batch has the same base name, when results under
    that name come from another input (a different file with different
    content), or when such suffixed results already exist (a resumed batch).
    The suffix is the measurement's, not its path's, so a folder moved keeps its
    results' names; results named by the path (before issue 53) are resumed.
    """
    material = safe_stem(measured.material)
    by_path = f"{material}-{_path_key(path)}"
    suffixed = by_path if any(folder.exists(result_name(by_path, m)) for m in models) else \
        f"{material}-{measured.provenance.sha256[:8]}"
    if collides or any(folder.exists(result_name(suffixed, m)) for m in models):
        return suffixed
    for model in models:
        other = folder.load(result_name(material, model))
        other_file = (other.provenance.get("file") or "") if other is not None else ""
        if other is not None and other.provenance.get("sha256") != measured.provenance.sha256 \
                and os.path.abspath(other_file) != os.path.abspath(path):
            return suffixed
    # another input of this name may be being fitted at this moment by another worker, its
    # results not written yet: the name goes to the first input to claim it
    return material if folder.claim(material, measured.provenance.sha256, path) else suffixed


def load_quietly(path):
    if not path.exists():
        return None
    try:
        return FitResult.load(path)
    except ResultFileError:
        return None


def finished(result, sha256, options, refit_stale=False):
    """``result`` if it is one of the same input file with the same fit options (and,
    with ``refit_stale``, of this toolkit's version), else None."""
    if result is None or result.provenance.get("sha256") != sha256:
        return None
    if refit_stale and result.toolkit_version != __version__:
        return None
    return result if result.optimizer.get("options") == options else None


def moved(result, absolute):
    """``result`` with its provenance naming the input at ``absolute``, when the file it
    names is gone (its folder moved: the same sha256 found here); else None."""
    from brdf_fit.errors import is_file_here
    old = result.provenance.get("file")
    if not old or old == absolute or is_file_here(old):
        return None
    return dataclasses.replace(result, provenance={**result.provenance, "file": absolute})
