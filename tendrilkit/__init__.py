"""tendrilkit: 3D shape of tendrils from three calibrated views.

Implements Fan, Visentin, Mazzolai and Del Dottore, "Image-based Morphological
Characterization of Filamentous Biological Structures with Non-constant
Curvature Shape Feature" (IJCV 2025).
"""

__version__ = "0.1.0"

from tendrilkit._numba_cache import drop_stale_caches as _drop_stale_caches

# numba checks a cached function against its own file only: a compiled caller of a changed compiled
# module would keep the old code (tendrilkit._numba_cache)
_drop_stale_caches(__path__[0])
