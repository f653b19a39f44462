"""Scene factors of the random phantom scenes: which difficulties a scene has.

A random scene (:mod:`tendrilkit.phantom.scenes`) is the site phantom's world
(:mod:`tendrilkit.phantom`) with the difficulties of real recordings switched
on one by one. This module only decides *which* factors a scene has, from its
seed and a preset name; :mod:`tendrilkit.phantom.scenes.make` realises them.

Factors (``name``: what it does):

- ``shape`` (categorical): ``slight`` (S1 family), ``hook`` (planar curl,
  S2 or S4 family), ``loop`` (off-plane loop, S3 family), ``coil`` (helical
  coil of 2-3 turns, radius 4-10 mm, at the distal part), ``coil_endon`` (a
  coil whose axis points at one camera), ``multi_crossing`` (a coil whose
  projection crosses itself at least twice in at least two views).
- ``sampling`` (categorical): ``timelapse`` (one frame every 15 s, a 15 s
  window of a 15-minute response), ``sparse`` (one frame every 15 s, the
  whole response in the sequence: large changes between frames), ``fps30``
  (30 frames per second: nearly identical frames).
- ``look`` (categorical): ``default`` (1.5 mm green tube), ``pale`` (pale,
  0.8-2 mm, tapering to the tip: low contrast in every channel), ``brown``
  (brownish, tapering).
- Contact and clutter (booleans): ``over_leaf`` (a leaf on the board under
  the tendril: crossing in front of it in the views), ``over_stem`` (a side
  shoot of the stem on the board under the tendril), ``alongside`` (a side
  shoot on the board within 10-30 px of the tendril in one view),
  ``tip_leaf`` (a leaf the tip rests on for several frames),
  ``second_tendril`` (another tendril crossing the measured one in one view,
  in front of or behind it, never touching it in 3D), ``occluding_leaf`` (a
  leaf between one camera and the tendril, hiding part of it in that view).
- Marks (boolean): ``careless_marks`` (generous ROI, keep-out box offset and
  larger or smaller than needed, base point a few px off).
- Time (booleans): ``sway`` (pendulum sway of the whole tendril, a few mm
  at the tip), ``leave_view`` (the tendril partly leaves one view).
- Imaging (booleans): ``flicker`` (brightness drift and flicker, +-15 %),
  ``vignetting`` (strong), ``shadow`` (the tendril's soft shadow on the
  board), ``noise`` (sensor noise 4-8 grey levels), ``motion_blur`` (a
  short line blur per frame: camera shake), ``distortion`` (|k1| 0.06-0.1,
  the tendril partly in the outer third of a view), ``jpeg`` (every frame
  re-encoded as JPEG of quality 25-60: the blocking and ringing of H.264 at
  a low bit rate, a documented stand-in).
- ``markers`` (boolean): two to five markers in all, at least one small,
  one partly outside a view, the world marker 16-24 mm.
- ``behind_stem`` (boolean): a side shoot of the stem (2.4-3.4 mm thick)
  arching through space between one camera and the tendril: the tendril
  passes behind it in that view (the hidden arc lengths per frame and view
  are in the ground truth).
- ``petiole`` (boolean): a leaf's petiole (0.9-1.4 mm) from the stem with
  its blade, hanging in the ROI, crossing the tendril's projection in one
  view (in front of or behind it), never touching it in 3D.
- ``glancing_marker`` (boolean): a marker on a card standing on the board,
  tilted 58-78 degrees, seen at 60 degrees or more from its normal by at
  least one view (off the world marker's plane).

The three last factors were added after the first benchmark (scene version
2); they are drawn after the others, so a seed's other factors are unchanged.

``random`` draws every factor from the seed; a preset named after a factor
(or after a categorical value, e.g. ``coil`` or ``sparse``) switches that
factor alone on a clean scene; ``clean`` switches none; group presets
(``contact``, ``clutter``, ``imaging``, ``time``) switch a group. Presets
joined by ``+`` (e.g. ``coil+over_stem+tip_leaf``) switch all of theirs
together on a clean scene, the rest drawn from the seed as a preset draws
it (:func:`scene_parts`); at most one shape, one sampling and one look.
"""

from __future__ import annotations

import numpy as np

SHAPES = ("slight", "hook", "loop", "coil", "coil_endon", "multi_crossing")
SAMPLINGS = ("timelapse", "sparse", "fps30")
LOOKS = ("default", "pale", "brown")
BOOLEAN_FACTORS = ("over_leaf", "over_stem", "alongside", "tip_leaf", "second_tendril", "occluding_leaf",
                   "careless_marks", "sway", "leave_view", "flicker", "vignetting", "shadow", "noise",
                   "motion_blur", "distortion", "jpeg", "markers", "behind_stem", "petiole", "glancing_marker")
GROUPS = {
    "contact": ("over_leaf", "over_stem", "alongside", "tip_leaf"),
    "clutter": ("second_tendril", "occluding_leaf", "over_leaf", "alongside"),
    "imaging": ("flicker", "vignetting", "shadow", "noise", "motion_blur", "distortion", "jpeg"),
    "time": ("sway", "leave_view"),
}
#: Probability of each boolean factor in a ``random`` scene.
P_FACTOR = 0.2

PRESETS = (("random", "clean") + SHAPES + tuple(s for s in SAMPLINGS if s != "timelapse")
           + tuple(x for x in LOOKS if x != "default") + BOOLEAN_FACTORS + tuple(GROUPS))


def scene_parts(scene: str) -> tuple[str, ...]:
    """The presets a scene name switches on together: ``"coil+over_stem"`` -> ``("coil", "over_stem")``.

    Parameters
    ----------
    scene : str
        ``random``, a preset of :data:`PRESETS`, or presets (other than
        ``random`` and ``clean``) joined by ``+``.

    Returns
    -------
    tuple of str
        One name for ``random`` or a single preset.

    Raises
    ------
    ValueError
        An unknown name, ``random``/``clean`` in a combination, two
        shapes (samplings, looks) that cannot both hold, or a combination
        over 80 characters.

    Examples
    --------
    >>> scene_parts("coil+over_stem+tip_leaf")
    ('coil', 'over_stem', 'tip_leaf')
    """
    parts = tuple(str(scene).split("+"))
    bad = [p for p in parts if p not in PRESETS]
    if bad:
        raise ValueError(f"scene: expected one of {', '.join(PRESETS)} (or several joined by '+'), got "
                         f"{scene!r} ({', '.join(repr(b) for b in bad)} unknown)")
    if len(parts) == 1:
        return parts
    if len(scene) > 80:  # the experiment's name, scene-<scene>-seed<N>, is a folder name of at most 100
        raise ValueError(f"scene: expected at most 80 characters, got {len(scene)} in {scene!r}")
    if {"random", "clean"} & set(parts):
        raise ValueError(f"scene: 'random' and 'clean' cannot be combined with '+', got {scene!r}")
    for kind, values in (("shape", SHAPES), ("sampling", SAMPLINGS), ("look", LOOKS)):
        chosen = sorted({p for p in parts if p in values})
        if len(chosen) > 1:
            raise ValueError(f"scene: a scene has one {kind}, got {' and '.join(chosen)} in {scene!r}")
    return parts


def draw_factors(seed: int, scene: str = "random") -> dict:
    """The factors of scene ``scene`` with seed ``seed``.

    Parameters
    ----------
    seed : int
    scene : str
        ``random``, a preset (:data:`PRESETS`) or presets joined by ``+``
        (:func:`scene_parts`).

    Returns
    -------
    dict
        ``shape``, ``sampling``, ``look`` (str) and every name of
        :data:`BOOLEAN_FACTORS` (bool). When no preset names a shape, the
        shape is drawn from ``slight, hook, loop`` (a clean tendril).

    Raises
    ------
    ValueError
        Unknown scene name, or a combination that cannot hold (:func:`scene_parts`).
    """
    parts = scene_parts(scene)
    rng = np.random.default_rng([int(seed), 1111])
    # always draw the same stream, whatever the preset
    shape_r = SHAPES[int(rng.integers(len(SHAPES)))]
    shape_clean = ("slight", "hook", "hook", "loop")[int(rng.integers(4))]
    sampling_r = SAMPLINGS[int(rng.integers(len(SAMPLINGS)))]
    look_r = LOOKS[int(rng.integers(len(LOOKS)))]
    flags_r = {k: bool(rng.uniform() < P_FACTOR) for k in BOOLEAN_FACTORS}
    if scene == "random":
        return {"shape": shape_r, "sampling": sampling_r, "look": look_r, **flags_r}
    out = {"shape": shape_clean, "sampling": "timelapse", "look": "default", **{k: False for k in BOOLEAN_FACTORS}}
    for part in parts:
        if part in SHAPES:
            out["shape"] = part
        elif part in SAMPLINGS:
            out["sampling"] = part
        elif part in LOOKS:
            out["look"] = part
        elif part in BOOLEAN_FACTORS:
            out[part] = True
        elif part in GROUPS:
            for k in GROUPS[part]:
                out[k] = True
    return out


def active_factors(factors: dict) -> list[str]:
    """Names of the factors that differ from a clean scene, e.g. ``["shape=coil", "jpeg"]``.

    The shape is always listed (every scene has one); ``sampling`` and
    ``look`` when not the default.
    """
    out = [f"shape={factors['shape']}"]
    if factors["sampling"] != "timelapse":
        out.append(f"sampling={factors['sampling']}")
    if factors["look"] != "default":
        out.append(f"look={factors['look']}")
    out += [k for k in BOOLEAN_FACTORS if factors.get(k)]
    return out
