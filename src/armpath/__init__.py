"""armpath: motion design for serial arms driven by quantized incremental joint commands."""

__version__ = "0.1.0"
