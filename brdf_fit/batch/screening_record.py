"""A batch's screening record: ``MATERIAL.screening``, beside the results of one input.

With ``--models auto`` every model of an input is screened before the
contenders are fitted (fitting/screen.py, 2-5 s a MERL table), and a screened
model leaves no result file.  Without a record, a re-run on a finished folder
would screen every input again only to find its results done, and so would a
batch killed between two contenders of an input.  The record is written as
soon as the screening is known, before the first contender's fit: a re-run
takes the screened models from it and fits only the contenders it has no
result for.

It is JSON, but not named ``*.json``: the folder's readers (the summary, the
report, the notebook table) take every ``*.json`` for a result.  Like a
result file it is untrusted input: it is used only when it is readable
(at most MAX_RESULT_BYTES of UTF-8 JSON, parsed as a result file is: no
duplicate key, no oversized integer), every field has its type, every
number is a finite float, and its input (sha256), fit options, model list and
the screening's own settings (``settings``: fitting/screen.py's constants)
equal this run's.  Anything else is ignored: the input is screened again and
the record replaced.  ``--send-data`` workers see no record from before the
batch (``folder.ResultSnapshot``) and screen again.
"""

import json

from fitting import screen
from fitting.result_file import parse_json
from fitting.screen import ModelScreened

FORMAT = "brdf-fit screening record"
VERSION = 1       # bump when a record's fields change meaning: older records are ignored


def settings() -> dict[str, object]:
    """What decides a screening besides the input and the fit options: its samples, image,
    evaluations, tolerances (a small table's too), start inset, margin and number of contenders, and those of the
    glTF family screened apart (a record made with others is not used)."""
    from fitting.fit_models import APART_MARGIN, APART_MOST
    return {"samples": screen.SCREEN_SAMPLES, "image": screen.SCREEN_IMAGE, "evaluations": screen.SCREEN_EVALS,
            "tol": screen.SCREEN_TOL, "small_tol": screen.SMALL_SCREEN_TOL, "inset": screen.SCREEN_INSET,
            "margin": screen.SCREEN_MARGIN, "most": screen.SCREEN_MOST, "apart": [APART_MARGIN, APART_MOST]}


def record_name(material: str) -> str:
    """The file name of the screening record of ``material``: ``MATERIAL.screening``."""
    return f"{material}.screening"


class ScreeningRecord:
    """The screening record of one input in a batch's output folder (a ``folder.ResultFolder``
    or ``ResultSnapshot``): ``load`` the recorded screening if it is this run's, ``save`` a
    fresh one.  Neither raises: a record that cannot be read or written costs a screening."""

    def __init__(self, folder, material: str, sha256: str, options: dict[str, object],
                 models: tuple[str, ...]) -> None:
        self.folder, self.name = folder, record_name(material)
        self.sha256, self.options, self.models = sha256, options, list(models)

    def load(self) -> dict[str, ModelScreened] | None:
        """{model: ModelScreened} of the recorded screening, or None (see the module)."""
        text = self.folder.load_text(self.name)
        if text is None:
            return None
        try:
            data = parse_json(text, self.name)
            if not isinstance(data, dict) or not isinstance(data.get("screened"), list):
                return None
            screened = [ModelScreened.from_record(entry) for entry in data["screened"]]
        except ValueError:     # not JSON (ResultFileError), a field of the wrong type, NaN / Infinity
            return None
        by_model = {s.model: s for s in screened}
        if (data.get("format"), data.get("version"), data.get("sha256"), data.get("options"), data.get("models"),
                data.get("settings")) != (FORMAT, VERSION, self.sha256, self.options, self.models, settings()) \
                or len(by_model) != len(screened) or not set(by_model) <= set(self.models):
            return None
        return by_model

    def save(self, screened: dict[str, ModelScreened]) -> None:
        """Record ``screened`` (the screened models of a fresh screening), atomically; a
        record that cannot be written (a full disk, a non-finite number) is left out."""
        try:
            text = json.dumps({"format": FORMAT, "version": VERSION, "sha256": self.sha256,
                               "options": self.options, "models": self.models, "settings": settings(),
                               "screened": [s.to_record() for s in screened.values()]},
                              allow_nan=False, indent=1)
            self.folder.save_text(self.name, text + "\n")
        except (OSError, ValueError, TypeError):
            pass
