"""An end searched along the rim where the colour region ran on past it.

In turbid water the colour region of a pipe lying on a floor of nearly its colour can
run on beyond the pipe's end; the search along the rim starts at the region's extreme
(:class:`vision.end_search.RimSearch`: from ``inside_m`` inside it), so that end lies
outside the span searched. The pipe's straight edges stop at the end, though: where
nothing stands out from the region's extreme and the edges stop further inside, the
search runs again from where they stop. The scenes (``rim_scene.py``): a capped pipe
with one end in view, its edges drawn as the true cylinder's tangents up to 2 cm short
of the end, its colour region running on 0.3 m past it.
"""

from __future__ import annotations

import numpy as np
import pytest
from rim_scene import CAMS, PipeScene

from vision.detector import DetectorConfig, PipeEngine
from vision.silhouette import Silhouette

END = 0.3  # the visible end's axis coordinate (m); the pipe runs 1 m from it towards -a
EDGES = PipeScene((END - 1.0, END), (END - 0.7, END - 0.02), 40, END - 0.4)
REGION = PipeScene((END - 1.0, END), (END - 0.7, END + 0.3), 40, END - 0.4)


def _detect(yaw: float, seed: int):  # noqa: ANN202
    a = np.array([np.cos(yaw) * np.cos(0.1), np.sin(0.1), np.sin(yaw) * np.cos(0.1)])
    a /= np.linalg.norm(a)
    p = np.array([-0.1, 0.05, 1.0])
    rng = np.random.default_rng(seed)
    sils: list[Silhouette | None] = [
        REGION.view(p, a, CAMS[j][2], EDGES.edges(p, a, CAMS[j][2], (1, -1)), rng) for j in (0, 1)
    ]
    return PipeEngine(DetectorConfig())._fit(sils, CAMS, np.array([0.0, 1.0, 0.0]), None), p, a


@pytest.mark.parametrize(("yaw", "seed"), [(0.0, 1), (0.3, 2), (0.5, 3)])
def test_the_end_is_found_where_the_edges_stop(yaw: float, seed: int) -> None:
    """The end found along the rim within 1 cm (without the second search, from the region's
    extreme, none is: the span searched starts 0.18 m past the end)."""
    det, p, a = _detect(yaw, seed)
    assert det.quality["rim_search_ends"] == 1
    assert det.end_cam is not None
    assert float(np.linalg.norm(det.end_cam - (p + END * a))) < 0.01
    assert det.confidence > 0.7
