"""An interactive editor for subdivision curves (matplotlib), over a headless state.

```python
import jaxsubdiv as js
from jaxsubdiv.editor import Editor, EditorState

editor = Editor(js.shapes.get("star"), levels=5)   # a window, or a Jupyter widget
editor.show()

editor = Editor.from_fit("outline.svg", n_control=24)  # fit, then edit the fit

state = EditorState(js.shapes.get("star"), w=0.1)  # the same model, no matplotlib
state.move_vertex(0, (0.1, 1.2))
state.curve_points["four-point"], state.smoothness["four-point"]
```

Drag vertices, insert and delete them, toggle curves, set the level, tune `w`, `r`, `s`
and `t` with sliders and read each curve's smoothness; `s` saves JSON, SVG and PNG.
[`jaxsubdiv.editor.EditorState`][] is the model (polygon, edits, schemes, curves,
smoothness, fit, save; it imports no matplotlib); [`jaxsubdiv.editor.Editor`][] draws a
state in a matplotlib figure and maps mouse and keys (the table `KEYS`) to its methods.
Everything also runs headless (Agg). The command line: `jaxsubdiv edit [INPUT]`. See
`docs/editor.md`.
"""

from ._editor import (
    FIT_KEYS as FIT_KEYS,
    KEYS as KEYS,
    Editor as Editor,
    help_lines as help_lines,
)
from ._editor_state import (
    CURVES as CURVES,
    DEFAULT_CURVES as DEFAULT_CURVES,
    PARAMETERS as PARAMETERS,
    Curve as Curve,
    EditorState as EditorState,
    format_smoothness as format_smoothness,
)
