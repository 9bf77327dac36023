"""Puts this folder on ``sys.path`` (pytest's prepend import mode does so for a conftest's
folder), so the tests under ``classical/`` and ``learned/`` import the shared helpers
``instances`` and ``streets`` by name, as the tests beside them do."""
