"""The package version, in a leaf module: modules that record it (results files) import it
from here, not from :mod:`auvdock`, whose ``__init__`` re-exports the library API."""

__version__ = "0.1.0"
