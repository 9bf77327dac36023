"""The one safe file layer: every reader and writer of the package goes through it.

- reads take regular files only (a FIFO, device or socket is refused at once, never
  waited on), check the size before reading, and inside a folder the command owns do
  not follow links (:mod:`~inpaintenv.files.reading`);
- JSON is bounded in size and nesting (:mod:`~inpaintenv.files.jsonio`);
- every write goes to an exclusively created, unpredictably named temporary file (or
  folder) in the target's folder and is renamed over the target; appends and locks never
  follow a link (:mod:`~inpaintenv.files.writing`);
- every size bound lives in :mod:`~inpaintenv.files.limits`.
"""

from .jsonio import loads_json, read_json, write_json
from .limits import (
    MAX_FRAME_PIXELS,
    MAX_JSON_BYTES,
    MAX_JSON_DEPTH,
    MAX_SCAN_POINTS,
    MAX_TEXT_BYTES,
    check_frame_pixels,
)
from .reading import describe_kind, open_regular, read_bytes, read_head, read_text
from .writing import (
    TEMP_PREFIX,
    append_text,
    open_lock,
    remove_stale_temporaries,
    write_atomic,
    write_bytes_atomic,
    write_folder_atomic,
    write_text_atomic,
)

__all__ = [
    "MAX_FRAME_PIXELS", "MAX_JSON_BYTES", "MAX_JSON_DEPTH", "MAX_SCAN_POINTS", "MAX_TEXT_BYTES", "TEMP_PREFIX",
    "append_text", "check_frame_pixels", "describe_kind", "loads_json", "open_lock", "open_regular", "read_bytes",
    "read_head", "read_json", "read_text", "remove_stale_temporaries", "write_atomic", "write_bytes_atomic",
    "write_folder_atomic", "write_json", "write_text_atomic",
]
