"""How results are shown: per-frame rows and their tables, intervals, the look of every
figure, and progress lines.

=============  =========================================================================
module         what it holds
=============  =========================================================================
``results``    :class:`EvaluationResult`: per-frame rows, JSON / CSV / Markdown, merging
``tables``     summary tables (mean ± interval per group), one Markdown / CSV format
``stats``      bootstrap intervals of a mean and of a paired ratio
``style``      colour maps, method colours and hole drawing of every figure and panel
``progress``   counts, durations, progress bars and log lines of long runs
=============  =========================================================================

Every layer may use these (the data sources count frames with ``progress``, the env draws
with ``style``, ``evaluate`` returns an ``EvaluationResult``, the benchmark writes its
reports with all of them); they import only :mod:`inpaintenv.conventions` and
:mod:`inpaintenv.metrics`. Imports name the module (``from inpaintenv.report.tables
import to_markdown``); this face imports nothing, so a data source that counts frames
does not load the tables.
"""
