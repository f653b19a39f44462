"""The one route of the experiment's options to the stage functions.

Convention (CONTRIBUTING.md): each optional section's key is the keyword of
the same name of its stage's function (:data:`STAGE_FUNCTIONS`,
:data:`STAGE_SECTIONS`); the key's default lives only in that function's
signature, and the section of :mod:`tendrilkit.params` reads it from there
(:func:`stage_default`, when an experiment is first validated: the stage
modules are imported then, not with params). :func:`stage_options` gives
every stage its options, in the pipeline and the notebooks alike. Keys that
choose between functions or steps are the composer's :data:`SWITCHES`.
"""

from __future__ import annotations

from pathlib import Path

import ast
import importlib
import importlib.util
import inspect
from functools import cache
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from tendrilkit.params import Experiment

__all__ = ["STAGE_FUNCTIONS", "STAGE_SECTIONS", "SWITCHES", "stage_default", "stage_options",
           "stage_signature_defaults"]

#: The function each stage's options are keywords of (``module:function``).
STAGE_FUNCTIONS = {
    "segmentation": "tendrilkit.segmentation.component:segment_view",
    "ordering": "tendrilkit.skeleton.walk:order_skeleton",
    "correspondence": "tendrilkit.correspondence:match_epipolar",
    "triangulation": "tendrilkit.triangulation:triangulate",
    "multiview": "tendrilkit.multiview:reconstruct_multiview",
    "fit": "tendrilkit.pwc.fit:fit_piecewise_clothoid",
}
#: The experiment sections each stage reads, with the prefix of their keys'
#: keyword names: a key is the stage function's keyword of the same name, a
#: key of a section shared with another stage is prefixed with the section's
#: name (``smoothing.length_mm`` is the fit's ``smoothing_length_mm``).
STAGE_SECTIONS = {
    "segmentation": (("segmentation", ""),),
    "ordering": (("skeleton", ""), ("ordering", "")),
    "correspondence": (("correspondence", ""),),
    "triangulation": (("triangulation", ""),),
    "multiview": (("reconstruction", ""),),
    "fit": (("fit", ""), ("smoothing", "smoothing_")),
}
#: Keys the composer (:mod:`tendrilkit.pipeline`, :mod:`tendrilkit.runner`) acts on
#: itself, which choose between functions or steps: not stage keywords; their
#: defaults live in :mod:`tendrilkit.params`.
SWITCHES = {
    "correspondence": ("method",),
    "triangulation": ("to_curves", "base_from_marks"),
    "reconstruction": ("method", "chunk_frames", "front_line_contrast"),
}


@cache
def _signature_defaults(stage: str) -> tuple:
    """``(keyword, default)`` pairs of the stage function's signature.

    Read from the module's source (its syntax tree: literal defaults), so that
    validating an experiment file does not import every stage (numba, OpenCV,
    scikit-image: seconds); the function is imported and inspected only when
    its source cannot say (a non-literal default, a function defined
    elsewhere). ``tests/test_options_route.py`` checks both agree.
    """
    module, name = STAGE_FUNCTIONS[stage].split(":")
    origin = _source_file(module)
    if origin is not None:
        with open(origin, encoding="utf-8") as f:
            tree = ast.parse(f.read())
        for node in tree.body:
            if isinstance(node, ast.FunctionDef) and node.name == name:
                try:
                    return _literal_defaults(node.args)
                except ValueError:  # a default that is not a literal
                    break
    fn = getattr(importlib.import_module(module), name)
    return tuple((k, p.default) for k, p in inspect.signature(fn).parameters.items()
                 if p.default is not inspect.Parameter.empty)


def _source_file(module: str) -> Path | None:
    """The source file of a ``tendrilkit`` module, found without importing it (nor its parent package)."""
    parts = module.split(".")
    if parts[0] != "tendrilkit":
        return None
    base = Path(__file__).resolve().parent.joinpath(*parts[1:])
    for cand in (base.with_suffix(".py"), base / "__init__.py"):
        if cand.is_file():
            return cand
    return None


def _literal_defaults(args: ast.arguments) -> tuple:
    positional = args.posonlyargs + args.args
    pairs = list(zip([a.arg for a in positional[len(positional) - len(args.defaults):]], args.defaults))
    pairs += [(a.arg, d) for a, d in zip(args.kwonlyargs, args.kw_defaults) if d is not None]
    return tuple((k, ast.literal_eval(d)) for k, d in pairs)


def stage_signature_defaults(stage: str) -> dict[str, Any]:
    """The keyword defaults of a stage's function (:data:`STAGE_FUNCTIONS`).

    The one place an experiment option's default lives is its stage
    function's signature; the sections of :mod:`tendrilkit.params` read it
    from there (:func:`stage_default`), so the experiment file, the pipeline,
    the notebooks and a direct call of the function agree.
    """
    return dict(_signature_defaults(stage))


def stage_default(stage: str, keyword: str) -> Any:
    """The default of ``keyword`` in the signature of ``stage``'s function (imported when first needed).

    The sections of :mod:`tendrilkit.params` take their defaults from here
    (``Field(default_factory=lambda: stage_default(stage, key))``).
    """
    return stage_signature_defaults(stage)[keyword]


def stage_options(exp: Experiment, stage: str) -> dict[str, Any]:
    """The keyword options of a stage's function (:data:`STAGE_FUNCTIONS`) from an experiment.

    The one route from the experiment file to the stages: the pipeline and
    the notebooks call e.g. ``segment_view(image, ..., **stage_options(exp,
    "segmentation"))``. Every key of the stage's sections
    (:data:`STAGE_SECTIONS`) except the composer's :data:`SWITCHES` is
    passed, under its own name (another section's key: prefixed with the
    section's name).

    Parameters
    ----------
    exp : Experiment
    stage : {"segmentation", "ordering", "correspondence", "triangulation", "multiview", "fit"}

    Returns
    -------
    dict
        Keyword name to value (plain data: ``overrides`` as dicts).

    Examples
    --------
    >>> from tendrilkit.params import example_experiment_data, parse_experiment
    >>> exp = parse_experiment(example_experiment_data())
    >>> sorted(stage_options(exp, "correspondence"))
    ['depth_smoothing', 'max_distance_px']
    >>> stage_options(exp, "fit")["smoothing_length_mm"] is None
    True
    """
    if stage not in STAGE_SECTIONS:
        raise ValueError(f"stage must be one of {', '.join(STAGE_SECTIONS)}, got {stage!r}")
    out: dict[str, Any] = {}
    for section, prefix in STAGE_SECTIONS[stage]:
        for key, value in getattr(exp, section).model_dump().items():
            if key not in SWITCHES.get(section, ()):
                out[prefix + key] = value
    return out
