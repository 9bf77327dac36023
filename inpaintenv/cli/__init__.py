"""The ``inpaintenv`` command line: one module per subcommand and the options they share.

===================  ==================================================================
module               what it holds
===================  ==================================================================
``main``             the parser of every subcommand and ``main()`` (the console script)
``options``          the data-source options (KITTI or SyntheticStreets) and ``--quiet``
``method_options``   ``--checkpoint``, ``--on-bad-frame``, ``--unfilled``, method-name checks
``info``             ``inpaintenv info``: summarise a data source
``evaluate``         ``inpaintenv evaluate``: score methods, print one table
``show``             ``inpaintenv show``: one frame as a PNG panel
``benchmark``        ``inpaintenv benchmark``: a suite, resumable, with report and figures
``train``            ``inpaintenv train``: fit a named preset, resumably
``export``           ``inpaintenv export``: write the occluded inputs as files
``score``            ``inpaintenv score``: check and score a folder of predictions
``fill``             ``inpaintenv fill``: fill your own depth files and LiDAR scans
===================  ==================================================================

Subcommand modules import the two options modules and the layers below ``cli`` (never
this package face or each other), so each can be read alone.
"""

from .main import INTERRUPTED, SUBCOMMANDS, USER_ERRORS, build_parser, is_user_error, main
from .options import add_source_options, open_source_from_args

__all__ = ["INTERRUPTED", "SUBCOMMANDS", "USER_ERRORS", "add_source_options", "build_parser", "is_user_error", "main",
           "open_source_from_args"]
