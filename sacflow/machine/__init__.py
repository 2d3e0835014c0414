"""The machine: threads, memory allocator settings, environment variables, the kernel cache.

The lowest layer after :mod:`sacflow.errors`: it knows nothing of contact mechanics and imports
no other sacflow layer. See ``docs/architecture.md``.
"""
