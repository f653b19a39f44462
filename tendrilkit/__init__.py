"""tendrilkit: 3D shape of tendrils from three calibrated views.

Implements Fan, Visentin, Mazzolai and Del Dottore, "Image-based Morphological
Characterization of Filamentous Biological Structures with Non-constant
Curvature Shape Feature" (IJCV 2025).
"""

__version__ = "0.1.0"
