"""The JSON Schema of a result file (``brdf-fit schema``): every field, with its units.

``FitResult.from_dict`` is the validator the toolkit uses; this schema
documents the same format for other tools (and the tests check real results
against it with the ``jsonschema`` package).
"""

from .result import AT_BOUND_FRACTION, SCHEMA_VERSION

_NUMBER = {"type": "number"}
_RGB = {"type": "array", "items": _NUMBER, "minItems": 3, "maxItems": 3}


def _parameters():
    """Every parameter name any model string can have, with its description, unit and range."""
    from brdf.model import MODEL_EXAMPLES, parameter_schema, parse_model
    from .auto import AUTO_FAMILY
    found = {}
    for name in (*MODEL_EXAMPLES, *AUTO_FAMILY, "ggx_aniso+lambert+gltf_aniso", "gltf+ior+specular+aniso",
                 "lafortune3+lambert"):         # (Lafortune's lobes 2 and 3: brdf/lobes.py)
        for p in parameter_schema(parse_model(name)):
            lo, hi = found.get(p.name, (p, p.lower, p.upper))[1:]
            found[p.name] = (p, min(lo, p.lower), max(hi, p.upper))
    out = {}
    for name, (p, lo, hi) in sorted(found.items()):
        unit = f" [{p.unit}]" if p.unit else ""
        item = _RGB if p.size == 3 else _NUMBER
        out[name] = dict(item, description=f"{p.description}{unit}; range {lo:g} to {hi:g} "
                                           f"(per model: `brdf-fit models`, brdf.model.parameter_schema)")
    return out


def _per_channel(what):
    return dict(_RGB, description=f"{what} of the R, G and B channels")


def result_schema() -> dict[str, object]:
    """The schema as a dict (JSON Schema draft 2020-12)."""
    run = {"type": "object", "properties": {
        "stage": {"type": "integer", "description": "index of the stage, counting only the stages "
                                                     "that ran: the multi-start stage (every start on a "
                                                     "coarse part of the subsample), with the hybrid loss "
                                                     "the best start refined on that part, then the best "
                                                     "refined on the whole subsample (when the coarse part "
                                                     "was smaller), then the --polish run on the full set"},
        "samples": {"type": "integer", "description": "direction pairs the stage's optimizer saw"},
        "loss": {"type": "number", "description": "the stage's final loss on its samples"},
        "evaluations": {"type": "integer", "description": "loss+gradient evaluations of the run"},
        "converged": {"type": "boolean", "description": "the optimizer met its tolerance"}}}
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "urn:brdf-fit:result:1",
        "title": "brdf-fit result",
        "description": "One analytic BRDF model fitted to one measured file (brdf-fit fit / batch). "
                       "BRDF values are in 1/sr without the cosine; angles in degrees unless a "
                       "parameter says rad. Numbers are always finite.",
        "type": "object",
        "required": ["spec", "parameters", "errors", "schema_version"],
        # the toolkit's models: exactly the parameters listed (an own:NAME model: its file's)
        "if": {"properties": {"spec": {"not": {"pattern": "^own:"}}}},
        "then": {"properties": {"parameters": {"properties": _parameters(), "additionalProperties": False}}},
        "properties": {
            "spec": {"type": "string", "description": "canonical model string, e.g. ggx+lambert "
                                                      "(docs/models.md; `brdf-fit models`)"},
            "parameters": {"type": "object",     # their properties: "then" above (the toolkit's models)
                           "description": "the model's parameters: exactly those of its schema; RGB "
                                          "ones as [r, g, b] (linear), roughness perceptual "
                                          "(alpha = roughness^2, the glTF roughnessFactor); a model "
                                          "of one's own (own:NAME) has those its file declares"},
            "model_file": {"type": "object", "required": ["name", "sha256"], "additionalProperties": False,
                           "properties": {
                               "name": {"type": "string", "description": "the file's name"},
                               "sha256": {"type": "string", "description": "SHA-256 of the file's bytes: "
                                                                           "what identifies the file"},
                               "path": {"type": "string", "description": "the path the file was given by, "
                                                                         "as typed (not resolved): for the "
                                                                         "reader's information, never opened "
                                                                         "nor run from the result (absent in "
                                                                         "results written before it was "
                                                                         "recorded)"}},
                           "description": "own:NAME models only: the Python file that declared the model "
                                          "(docs/models.md, 'A model of your own'); reading the result "
                                          "needs that file given again"},
            "errors": {"type": "object", "description": "errors on the full measured set", "properties": {
                "m1": {"type": "number", "minimum": 0,
                       "description": "M1, the toolkit's table error: mean over R, G, B of the RMS of "
                                      "the cosine-weighted log difference (docs/metrics.md); "
                                      "dimensionless, lower is better"},
                "m1_per_channel": _per_channel("M1"),
                "loss_name": {"type": "string", "description": "the loss the optimizer minimised "
                                                               "(log = M1)"},
                "loss": {"type": "number", "minimum": 0, "description": "that loss on the full set"},
                "loss_per_channel": _per_channel("the loss"),
                "image": {"type": "number", "minimum": 0,
                          "description": "the image error: RMS over the pixels of the colour "
                                         "difference Delta E_ITP (ITU-R BT.2124) / 325 of the "
                                         "tone-mapped images of a lit sphere at the exposure set "
                                         "from the measured image, model vs measurement "
                                         "(docs/metrics.md); lower is better; absent when the "
                                         "measurement has no lookup"},
                "image_per_channel": dict(_RGB, description="the RMS of the image error's I, T and P "
                                                            "components (same unit)"),
                "image_fixed": {"type": "number", "minimum": 0,
                                "description": "the same image error with both images at the fixed "
                                               "exposure 1 (the second figure; docs/metrics.md)"},
                "second_image": {"type": "number", "minimum": 0,
                                 "description": "issue 59's second image error (fitting/second_error.py: "
                                                "one light at a time, Reinhard, sRGB RMS); only in a fit "
                                                "that weighed it (BRDF_SECOND_WEIGHT, docs/metrics.md)"},
                "exported_model": {"type": "string", "description": "the glTF BRDF `brdf-fit export` "
                                                                    "writes for this fit (docs/gltf.md)"},
                "exported_m1": {"type": "number", "minimum": 0,
                                "description": "M1 of that glTF material against the measurement"},
                "exported_image": {"type": "number", "minimum": 0,
                                   "description": "the image error of that glTF material"},
                "exported_second_image": {"type": "number", "minimum": 0,
                                          "description": "the second image error of that glTF material"},
                "blender_m1": {"type": "number", "minimum": 0,
                               "description": "M1 of that glTF material as Blender's importer reads it "
                                              "(F90 = 1; only for a material that is not portable: "
                                              "docs/gltf.md)"},
                "blender_image": {"type": "number", "minimum": 0,
                                  "description": "the image error of that glTF material as Blender's "
                                                 "importer reads it"}}},
            "optimizer": {"type": "object", "description": "how the fit ran", "properties": {
                "name": {"type": "string", "description": "optimizer (--optimizer)"},
                "starts": {"type": "integer", "description": "starting points of the multi-start "
                                                             "stage (one run each at stage 0)"},
                "runs": {"type": "array", "items": run, "description": "every optimizer run, in order "
                                                                       "(starts + refinement stages)"},
                "evaluations": {"type": "integer", "description": "sum of the runs' evaluations"},
                "converged": {"type": "boolean", "description": "the final run converged"},
                "seconds": {"type": "number", "description": "seconds in the optimizer runs"},
                "seconds_total": {"type": "number", "description": "seconds of the whole fit "
                                                                   "(scan, runs, full-set errors)"},
                "samples": {"type": "integer", "description": "size of the subsample the optimizer saw"},
                "samples_full": {"type": "integer", "description": "valid pairs in the full set"},
                "polish": {"type": "boolean", "description": "--polish was given"},
                "max_theta": {"type": "number", "description": "grazing cut-off [degrees]: pairs with "
                                                               "theta_i or theta_o above it are left out"},
                "seed": {"type": "integer", "description": "seed of the subsample"},
                "options": {"type": "object", "description": "the options the fit was asked for; a "
                                                            "batch resumes a result only if they equal "
                                                            "the new run's"}}},
            "provenance": {"type": "object", "description": "the measured input", "properties": {
                "file": {"type": ["string", "null"], "description": "the measured file's path when it was "
                                                                   "loaded"},
                "sha256": {"type": ["string", "null"], "description": "SHA-256 of the file's bytes"},
                "format": {"type": ["string", "null"], "description": "merl, utia, rgl, csv or npz"},
                "material": {"type": ["string", "null"], "description": "material name"}}},
            "toolkit_version": {"type": "string", "description": "brdf-fit version that wrote it"},
            "schema_version": {"const": SCHEMA_VERSION, "description": "this format's version"},
            "created": {"type": "string", "description": "when the fit was made: ISO 8601 UTC, "
                                                         "e.g. 2026-12-01T16:05:09Z"},
            "at_bounds": {"type": "object", "additionalProperties": {"enum": ["lower", "upper"]},
                          "description": f"parameters within {AT_BOUND_FRACTION:.0%} of their range's "
                                         "lower or upper end, of log x for a parameter on a log scale "
                                         "(the data may want a value outside the range); derived from "
                                         "the parameters"},
        },
    }
