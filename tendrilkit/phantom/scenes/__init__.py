"""Random phantom scenes like real recordings (issue 11): the site phantom's world with its difficulties.

- :mod:`~tendrilkit.phantom.scenes.factors`: which factors a scene has (drawn
  from the seed, or one preset alone);
- :mod:`~tendrilkit.phantom.scenes.make`: :func:`make_scene`, the tendril's
  shape, times, cameras, imaging and the constraints;
- :mod:`~tendrilkit.phantom.scenes.clutter`: objects near the tendril (on
  the board, in space, shoots and petioles crossing it), careless marks;
- :mod:`~tendrilkit.phantom.scenes.markers`: markers as people tape them
  (small, across an image edge, on a tilted card);
- :mod:`~tendrilkit.phantom.scenes.render`: the frames (:func:`render_scene_view`);
- :mod:`~tendrilkit.phantom.scenes.experiment`: the experiment file's text and
  ``gt_meta.json``.

Files are written by :func:`tendrilkit.io.phantom.write_scene_experiment`
(also :func:`tendrilkit.phantom.write_scene_experiment`). Seeds 0-9999 are for
development, 10000 and above are reserved for ``benchmarks/bench_generalize.py``.
Every seed makes a scene: when the seed's 40 attempts fail, further rounds
(derived sub-seeds) go on; a scene that needed them says so in
``realised["generation"]``.
"""

from tendrilkit.phantom.scenes.factors import (BOOLEAN_FACTORS, GROUPS, LOOKS, PRESETS, SAMPLINGS, SHAPES,
                                               active_factors, draw_factors, scene_parts)
from tendrilkit.phantom.scenes.make import DEFAULT_SCENE_FRAMES, SCENE_VERSION, ScenePhantom, make_scene
from tendrilkit.phantom.scenes.render import render_scene_view

__all__ = ["BOOLEAN_FACTORS", "DEFAULT_SCENE_FRAMES", "GROUPS", "LOOKS", "PRESETS", "SAMPLINGS", "SCENE_VERSION", "SHAPES",
           "ScenePhantom", "active_factors", "draw_factors", "make_scene", "render_scene_view", "scene_parts"]
