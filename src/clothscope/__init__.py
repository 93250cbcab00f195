"""clothscope: fabric type and cloth-simulation parameters from one photo of cloth."""

from clothscope.core.runtime import ensure_libllvm

__version__ = "0.1.0"

# drjit picks its libLLVM when it is first imported, so the choice is made before any clothscope module imports it.
ensure_libllvm()
