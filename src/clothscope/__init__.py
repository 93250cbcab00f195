"""clothscope: fabric type and cloth-simulation parameters from one photo of cloth."""

__version__ = "0.1.0"
