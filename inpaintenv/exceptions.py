"""Every error inpaintenv and its estimators raise on purpose, in one place.

Each class derives from :class:`InpaintenvError` and keeps the built-in base it always had,
so ``except ValueError`` (or ``OSError``, ``KeyError``, ...) still catches it, as in
scikit-learn's ``sklearn.exceptions``::

    InpaintenvError
    ├── InvalidInputError (ValueError)     a value breaks a documented rule
    │   ├── DataError                      a data file or frame cannot be used
    │   │   ├── BadFrameError, CalibrationError, DepthFormatError,
    │   │   └── ScanFormatError, StaleCacheError
    │   ├── CheckpointError                a saved model cannot be loaded
    │   ├── ForeignFolderError, RunMismatchError, RunStateError   (run folders)
    │   ├── ManifestError, SubmissionError, UnsafeFileError        (submissions)
    │   └── MethodOutputError, UnfilledPixelsError                 (a method's output)
    ├── InvalidTypeError (TypeError)       a value of the wrong type
    ├── UnknownNameError (KeyError)        no method, protocol, suite or check of that name
    ├── OutOfRangeError (IndexError)       a frame index past the end of a source
    ├── MissingDependencyError (ImportError)  an optional extra or a user's module is missing
    ├── StateError (RuntimeError)          a call in the wrong order (step before reset)
    ├── TrainingDivergedError (FloatingPointError)  a training loss became NaN or inf
    ├── ClusterError (RuntimeError)        a distributed run could not finish
    └── FileTooLargeError, RunLockedError, WorkerDataError (OSError)

The ``inpaintenv`` command prints an :class:`InpaintenvError` (or an ``OSError``) as one
line and exits with status 1; any other exception is a bug and shows its traceback.
The modules that raise these classes still export them under their old paths
(``from inpaintenv.data.io import DepthFormatError`` works).
"""

from __future__ import annotations

__all__ = [
    "BadFrameError", "CalibrationError", "CheckpointError", "ClusterError", "DataError", "DepthFormatError",
    "FileTooLargeError", "ForeignFolderError", "InpaintenvError", "InvalidInputError", "InvalidTypeError", "JSONFileError",
    "ManifestError", "MethodOutputError", "MissingDependencyError", "OutOfRangeError", "ResultRowError", "RunLockedError",
    "RunMismatchError", "RunStateError", "ScanFormatError", "StaleCacheError", "StateError", "SubmissionError",
    "TrainingDivergedError", "UnfilledPixelsError", "UnknownNameError", "UnsafeFileError", "WorkerDataError",
]


class InpaintenvError(Exception):
    """Base of every error inpaintenv raises on purpose (bad input, a missing extra, a lost cluster)."""


# --- the generic kinds ------------------------------------------------------------------


class InvalidInputError(InpaintenvError, ValueError):
    """A value breaks a documented rule (a shape, a range, an option); the message names it."""


class InvalidTypeError(InpaintenvError, TypeError):
    """A value of the wrong type (a string where a list of names is needed, a float seed)."""


class UnknownNameError(InpaintenvError, KeyError):
    """No method, protocol, suite or check of that name; the message lists the known ones."""

    def __str__(self) -> str:
        # KeyError's str() is the repr of its key; this one's argument is a sentence.
        return str(self.args[0]) if len(self.args) == 1 else super().__str__()


class OutOfRangeError(InpaintenvError, IndexError):
    """A frame index outside the data source."""


class MissingDependencyError(InpaintenvError, ImportError):
    """A module something needs cannot be imported: an optional extra that is not installed
    (the message says what to install), or the module of a user's ``-m module:function``."""


class StateError(InpaintenvError, RuntimeError):
    """A call in the wrong order (an environment stepped before ``reset``)."""


# --- data --------------------------------------------------------------------------------


class DataError(InvalidInputError):
    """A data file, folder or frame that cannot be used; the message names it."""


class BadFrameError(DataError):
    """A ground-truth frame cannot be read or breaks the depth convention (the message names it)."""


class CalibrationError(DataError):
    """A calibration file or folder that cannot be read or lacks a matrix; the message names it."""


class DepthFormatError(DataError):
    """A file exists but is not a KITTI 16-bit single-channel depth PNG."""


class ScanFormatError(DataError):
    """A file that is not a KITTI LiDAR scan (``N x 4`` float32); the message names it."""


class StaleCacheError(DataError):
    """The cache folder holds frames of another dataset (other ids, shape or source)."""


class JSONFileError(DataError):
    """A JSON document that is broken, nested too deeply or holds a value it may not (NaN)."""


class FileTooLargeError(InpaintenvError, OSError):
    """A file is larger than what it holds can need (read with a ``limit``); it is not read."""


# --- methods and models --------------------------------------------------------------------


class MethodOutputError(InvalidInputError):
    """A method returned an unusable reconstruction (wrong shape, NaN/inf, negative, above 255.996 m)."""


class UnfilledPixelsError(InvalidInputError):
    """A prediction is 0 m (unfilled) at hole pixels with ground truth and ``unfilled="error"``."""


class CheckpointError(InvalidInputError):
    """A saved model folder that cannot be loaded (missing, altered or of another format)."""


class TrainingDivergedError(InpaintenvError, FloatingPointError):
    """A training loss became NaN or inf (the message says at which step and what to lower)."""


# --- runs, clusters and submissions --------------------------------------------------------


class RunMismatchError(InvalidInputError):
    """The output folder holds rows of a different run (other data, seeds, protocols, or
    another model under the same method name)."""


class RunStateError(InvalidInputError):
    """The output folder's ``run.json`` (the resume state) cannot be read."""


class ResultRowError(InvalidInputError):
    """A per-frame result row holds what no scoring gives (a negative error, a metric out of
    its range, a bool for a number), or is not a row of the run that reads it."""


class ForeignFolderError(InvalidInputError):
    """The run folder holds a file that inpaintenv did not write where a run would write it."""


class RunLockedError(InpaintenvError, OSError):
    """Another live process holds the run folder's lock."""


class ClusterError(InpaintenvError, RuntimeError):
    """A distributed run could not finish: no scheduler or worker, workers that keep
    dying, no shard finishing within the shard timeout, or the scheduler or client
    lost mid-run."""


class WorkerDataError(InpaintenvError, OSError):
    """A worker cannot read the data source (the message names the worker and the path)."""


class SubmissionError(InvalidInputError):
    """Predictions that cannot be scored: missing, unexpected or unusable files (all listed)."""


class UnsafeFileError(InvalidInputError):
    """A file the package will not read or write: a FIFO, device or socket, a link inside a
    folder the command owns, outside its folder, or text that does not decode."""


class ManifestError(InvalidInputError):
    """A manifest cannot be read, or does not match the protocol or ground truth here."""
