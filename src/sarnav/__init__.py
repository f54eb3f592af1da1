"""sarnav: GPS-denied navigation aided by synthetic aperture radar.

See docs/architecture.md for the package layout and docs/conventions.md for frames,
units, attitude and error-state conventions.
"""

__version__ = "0.2.0"
