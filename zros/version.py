"""The version of zros (a leaf module: any part of zros may import it)."""

__version__ = '0.1.0'
