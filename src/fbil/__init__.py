"""fbil: fast imitation learning with forward-backward behavior foundation models."""

from fbil.errors import FbilError

__version__ = "0.1.0"

__all__ = ["FbilError", "__version__"]
