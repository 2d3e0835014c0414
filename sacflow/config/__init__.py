"""Configuration: the case schema (pydantic), overrides, and the one-screen error messages.

Reads no file: :mod:`sacflow.storage.case_file` reads case files and calls into this layer.
See ``docs/architecture.md``.
"""
