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
(``contact``, ``clutter``, ``imaging``, ``time``) switch a group.
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


def draw_factors(seed: int, scene: str = "random") -> dict:
    """The factors of scene ``scene`` with seed ``seed``.

    Parameters
    ----------
    seed : int
    scene : str
        ``random`` or a preset (:data:`PRESETS`).

    Returns
    -------
    dict
        ``shape``, ``sampling``, ``look`` (str) and every name of
        :data:`BOOLEAN_FACTORS` (bool). For presets other than a shape the
        shape is drawn from ``slight, hook, loop`` (a clean tendril).

    Raises
    ------
    ValueError
        Unknown scene name.
    """
    if scene not in PRESETS:
        raise ValueError(f"scene: expected one of {', '.join(PRESETS)}, got {scene!r}")
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
    if scene in SHAPES:
        out["shape"] = scene
    elif scene in SAMPLINGS:
        out["sampling"] = scene
    elif scene in LOOKS:
        out["look"] = scene
    elif scene in BOOLEAN_FACTORS:
        out[scene] = True
    elif scene in GROUPS:
        for k in GROUPS[scene]:
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
