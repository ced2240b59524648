"""sloshid: measure liquid sloshing from video, identify its pendulum model, plan slosh-free moves."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("sloshid")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"
