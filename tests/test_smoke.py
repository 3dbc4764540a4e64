import numpy as np

import jaxsubdiv as js
from helpers import chaikin_python


def test_chaikin_matches_plain_python():
    P = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    np.testing.assert_allclose(js.refine(P, js.Chaikin(), 3), chaikin_python(P, 3, True))
