"""An interactive editor for subdivision curves (matplotlib).

```python
import jaxsubdiv as js
from jaxsubdiv.editor import Editor

editor = Editor(js.shapes.get("star"), levels=5)   # a window, or a Jupyter widget
editor.show()

editor = Editor.from_fit("outline.svg", n_control=24)  # fit, then edit the fit
```

Drag vertices, insert and delete them, toggle curves, set the level, tune `w`, `r`, `s`
and `t` with sliders and read each curve's smoothness; `s` saves JSON, SVG and PNG.
Everything also runs headless (Agg), driven by matplotlib events or by the methods of
[`jaxsubdiv.editor.Editor`][]. The command line: `jaxsubdiv edit [INPUT]`. See
`docs/editor.md`.
"""

from ._editor import (
    CURVES as CURVES,
    DEFAULT_CURVES as DEFAULT_CURVES,
    PARAMETERS as PARAMETERS,
    Editor as Editor,
    format_smoothness as format_smoothness,
)
