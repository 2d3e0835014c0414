"""Mechanics on arrays: contact, hardening and return mapping, closed forms, fatigue, shakedown.

Functions take numpy arrays and plain parameters (SI units) and return arrays; they import
neither pydantic nor the case schema. Only :mod:`sacflow.machine`, :mod:`sacflow.kernels` and
:mod:`sacflow.errors` lie below. See ``docs/architecture.md``.
"""
