"""The texture models, NumPy and SciPy only (no Warp): the ``Texton`` value and its files,
the analysis of an example (EUSIPCO Alg. 2, CGF Alg. 1), Gaussian models, histogram
transforms, B-splines and discrete spot noise.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.lazy import lazy_names

if TYPE_CHECKING:
    from .texton import Texton, load_texton
    from .analysis import analyze, model_error
    from .gaussian import gaussian_texture, periodic_component
    from .histogram import HistogramTransform
    from .spot_noise import dsn
    from .structure import structure_score
    from .tiling import TilingModel, suggest_method
    from .analysis_options import AnalysisOptions
    from .example_checks import downscale

#: The module of each name of this room's face, imported on first use (PEP 562).
_LAZY = {
    "Texton": "texton",
    "load_texton": "texton",
    "analyze": "analysis",
    "model_error": "analysis",
    "gaussian_texture": "gaussian",
    "periodic_component": "gaussian",
    "HistogramTransform": "histogram",
    "dsn": "spot_noise",
    "TilingModel": "tiling",
    "structure_score": "structure",
    "suggest_method": "tiling",
    "AnalysisOptions": "analysis_options",
    "downscale": "example_checks",
}

__all__ = ["AnalysisOptions", "HistogramTransform", "Texton", "TilingModel", "analyze", "downscale", "dsn", "gaussian_texture", "load_texton", "model_error", "periodic_component", "structure_score", "suggest_method"]


__getattr__, __dir__ = lazy_names(__name__, _LAZY)
