"""What a value may be, checked where it enters: one module per kind of value.

The file layer (:mod:`inpaintenv.files`) checks that a file is safe to read; this package
checks that what it holds is possible. Each module owns one kind of value and is called
by every reader of that kind, so a new reader cannot forget the check:

Import a check from its module (``from inpaintenv.values.points import ...``); this
package imports nothing else, so every layer may use it.
"""
