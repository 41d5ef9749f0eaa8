"""Imported first by the fork server (its preload list, :func:`pipeline.batch.pool.pool_context`):
the server dies with the process that started it, even while it is still importing the
heavy modules that follow (seconds), instead of noticing only afterwards
(:func:`pipeline.batch.interrupt.die_with_parent`; the owner's pid is in ``$PIPELINE_OWNER``).
Importing it anywhere else does nothing."""

import os

from .interrupt import die_with_parent

OWNER_ENV = "PIPELINE_OWNER"

if os.environ.get(OWNER_ENV) == str(os.getppid()):
    die_with_parent()
    if os.environ.get(OWNER_ENV) != str(os.getppid()):  # the owner died before the guard
        os._exit(1)
