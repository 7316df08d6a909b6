"""CLI sub-commands, one module each.

Every module here defines ``register(subparsers)``, which adds its parser and
sets ``func`` to a callable ``(args) -> int`` (the exit code).  Modules are
discovered automatically by :mod:`kfio.service.cli`.
"""
