"""Interactive 3D viewer (viser): the arm with joint sliders, the scene, replays of results,
and self-contained HTML exports of replays."""
