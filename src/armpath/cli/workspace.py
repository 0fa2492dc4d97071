"""``armpath workspace``, ``blindzones`` and ``design-sweep``: reach, blind zones and the design
study.

Every size option is checked against the limits of :mod:`armpath.budget` before any work (one
``error:`` line naming the option); ``--time-limit`` bounds the wall-clock time, and progress
goes to stderr (lines when stderr is not a terminal).
"""

from __future__ import annotations

import contextlib
import dataclasses
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
import typer
from numpy.typing import NDArray
from rich import box
from rich.markup import escape
from rich.table import Table

from armpath.budget import (
    MAX_BANDS,
    MAX_CHUNK,
    MAX_GRID_CELLS,
    MAX_JOBS,
    MAX_SAMPLES,
    check_size,
)
from armpath.cli.common import (
    LinkRadiusOption,
    SceneOption,
    TimeLimitOption,
    TipLinkOption,
    WallOption,
    _arm,
    _cli_errors,
    _scene,
    app,
    err_console,
    out_console,
    print_written,
    progress,
    task_setup,
)
from armpath.errors import InvalidInputError

if TYPE_CHECKING:
    from armpath.export import OutputFolder
    from armpath.geometry.primitives import SolidOfRevolution
    from armpath.model.serial_arm import SerialArm
    from armpath.scenes import Scene


def _check_seed(seed: int) -> None:
    if seed < 0:
        raise InvalidInputError(f"--seed must be >= 0, got {seed}")


def _check_length(value: float, what: str, option: str) -> None:
    if not (np.isfinite(value) and value > 0):
        raise InvalidInputError(f"{what} ({option}) must be a positive length in mm, got {value}")


def _percent_steps(say: Callable[[str], None], what: str) -> Callable[[int, int], None]:
    """A ``progress(done, total)`` callback that reports ``what`` in steps of 5 %."""

    def report(done: int, total: int) -> None:
        say(f"{what}: {5 * (20 * done // max(total, 1)):d} % of {total:,}")

    return report


#: ``armpath workspace --method``: the parser's choices (--help lists them; another value is a
#: usage error, exit status 2); the same as :data:`armpath.workspace.sampling.METHODS`
#: (``tests/test_cli.py`` checks), spelled out so that --help need not import the sampler.
SamplingMethod = Literal["uniform", "stratified"]


@app.command()
def workspace(
    model: Annotated[
        str | None,
        typer.Option(
            "--model",
            help="Built-in model or a robot file (.json D-H table or .urdf). Default: the "
            "scene's \\[arm], else the seed arm; a model given stands where the scene's \\[arm] "
            "places it.",
            show_default=False,
        ),
    ] = None,
    tip_link: TipLinkOption = None,
    samples: Annotated[
        int,
        typer.Option(
            help="Joint vectors to sample (streamed in chunks of --chunk; at most "
            f"{MAX_SAMPLES:,})."
        ),
    ] = 4_000_000,
    voxel: Annotated[
        float,
        typer.Option(help=f"Voxel edge, mm (at most {MAX_GRID_CELLS:,} voxels over the reach)."),
    ] = 20.0,
    method: Annotated[
        SamplingMethod,
        typer.Option(help="uniform, or stratified (a Latin hypercube per chunk)."),
    ] = "uniform",
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same workspace).")] = 0,
    chunk: Annotated[
        int, typer.Option(help=f"Samples per chunk (bounds the memory; at most {MAX_CHUNK:,}).")
    ] = 1_000_000,
    obstacles: Annotated[
        bool,
        typer.Option(
            "--obstacles",
            help="Keep only configurations that satisfy the scene's clearance rule "
            "(obstacles and self-collision; the scene of --scene, else the seed scene for the "
            "seed arm and no obstacles for another --model: the arm alone, its links against "
            "each other).",
        ),
    ] = False,
    scene_file: SceneOption = None,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out", help="Write workspace.npz, workspace.csv and workspace_sections.png here."
        ),
    ] = None,
    time_limit: TimeLimitOption = None,
) -> None:
    """Reachable workspace of the tool point by sampling joint space into voxels: volume,
    bounding box and sections."""
    from armpath.export import output_folder
    from armpath.kinematics import z_axis_chain
    from armpath.workspace import sample_workspace
    from armpath.workspace.sampling import METHODS, GridSpec, check_count

    with _cli_errors(time_limit):
        check_count(samples, "--samples", MAX_SAMPLES, "joint samples")
        check_count(chunk, "--chunk", MAX_CHUNK, "joint samples a chunk")
        if method not in METHODS:
            raise InvalidInputError(f"--method must be one of {METHODS}, got {method!r}")
        _check_seed(seed)
        _check_length(voxel, "voxel size", "--voxel")
        # the arm and the scene as every task takes them: the seed scene for the seed arm,
        # another arm alone; a scene's [arm] places the arm (and gives it, without --model)
        arm, the_scene = task_setup(model, scene_file, None, None, tip_link)
        GridSpec.for_arm(arm, voxel, "--voxel")
        world = the_scene.world if obstacles else None
        folder_cm = output_folder(out) if out is not None else contextlib.nullcontext()
        with folder_cm as folder:
            t0 = time.perf_counter()
            with progress(f"sampling the workspace of {arm.name} ...") as say:
                grid = sample_workspace(
                    arm,
                    samples,
                    voxel,
                    seed=seed,
                    method=method,
                    chunk=chunk,
                    world=world,
                    progress=_percent_steps(say, "sampling"),
                )
            seconds = time.perf_counter() - t0
            lo, hi = grid.bounding_box()
            rows: list[tuple[str, str, str]] = [
                ("model", arm.name, ""),
                ("samples", f"{grid.samples}", ""),
                *(
                    [("kept (clearance rule)", f"{grid.kept}", f"scene: {the_scene.name}")]
                    if obstacles
                    else []
                ),
                ("voxel", f"{grid.voxel:g}", "mm"),
                ("occupied voxels", f"{grid.n_occupied}", ""),
                ("volume", f"{grid.volume / 1e9:.4f}", "m^3"),
                ("x range", f"{lo[0]:.0f} .. {hi[0]:.0f}", "mm"),
                ("y range", f"{lo[1]:.0f} .. {hi[1]:.0f}", "mm"),
                ("z range", f"{lo[2]:.0f} .. {hi[2]:.0f}", "mm"),
                *_one_voxel_thick(lo, hi, grid.voxel),
                ("time", f"{seconds:.1f}", "s"),
                ("rate", f"{grid.samples / seconds / 1e6:.2f}", "million samples/s"),
            ]
            table = Table(title=escape(f"workspace of {arm.name}"), box=box.SIMPLE)
            for name in ("quantity", "value", "unit"):
                table.add_column(name)
            for row in rows:
                table.add_row(*row)
            out_console.print(table)
            if folder is not None:
                from armpath.viz.workspace_figures import plot_workspace_sections

                np.savez_compressed(
                    folder.file("workspace.npz"),
                    occupied=grid.occupied,
                    origin_mm=grid.origin,
                    voxel_mm=grid.voxel,
                    samples=grid.samples,
                    kept=grid.kept,
                )
                folder.write_text(
                    "workspace.csv",
                    "quantity,value,unit\n"
                    + "".join(f"{n},{v.replace(',', ' ')},{u}\n" for n, v, u in rows),
                )
                # vertical section through axis 1, horizontal one half-way up the workspace
                centre = np.asarray(z_axis_chain(arm)[0, :3, 3]).copy()
                centre[2] = 0.5 * (lo[2] + hi[2])
                plot_workspace_sections(
                    folder.file("workspace_sections.png"),
                    grid,
                    centre,
                    f"{arm.name}: {grid.volume / 1e9:.4f} m^3 reachable "
                    f"({grid.samples:,} samples, {grid.voxel:g} mm voxels)",
                )
        if out is not None and folder is not None:
            print_written(folder)


def _one_voxel_thick(
    lo: NDArray[np.float64], hi: NDArray[np.float64], voxel_mm: float
) -> list[tuple[str, str, str]]:
    """A table row where the occupied voxels span one layer along an axis (a planar arm's
    workspace): the volume counts whole voxels there, the points themselves may have none."""
    flat = [axis for axis, span in zip("xyz", hi - lo, strict=True) if span <= voxel_mm * 1.000001]
    if not flat:
        return []
    return [
        (
            "note",
            f"one voxel thick in {' and '.join(flat)}: the volume counts whole {voxel_mm:g} mm "
            "voxels; the points reached may lie in a plane, with no volume",
            "",
        )
    ]


def _only_workpiece(scene: Scene) -> SolidOfRevolution:
    if len(scene.workpieces) != 1:
        raise InvalidInputError(
            f"scene {scene.name!r} has {len(scene.workpieces)} hollow workpieces; "
            "blind zones need exactly one"
        )
    return scene.workpieces[0]


@dataclasses.dataclass(frozen=True)
class _BlindZones:
    plane: Any
    meridian: Any
    faces: list[Any]
    pixel: float

    def warnings(self, pixel: float) -> list[str]:
        """A warning for each map whose blind zone had not settled (too few samples for the
        pixels: the unfilled reachable pixels count as blind)."""
        return [
            f"warning: over the second half of its {m.samples:,} "
            f"sample{'' if m.samples == 1 else 's'} the {what} map's "
            f"reachable area went from {m.half_reach_area:.0f} to {m.reach_area:.0f} mm^2 and "
            f"its blind zone from {m.half_blind_area:.0f} to {m.blind_area:.0f} mm^2: too few "
            f"samples for {pixel:g} mm pixels, and its figures are not settled (more "
            "--samples or a larger --pixel)"
            for what, m in (("arm-plane", self.plane), ("meridian", self.meridian))
            if not m.settled and m.half_blind_area is not None and m.half_reach_area is not None
        ]

    def summary(self) -> list[str]:
        """One line each: the central blind zone in the plane and in 3-D, each face."""
        out = [
            f"central blind zone: {self.plane.blind_area / 100:.0f} cm^2 in the arm plane "
            f"(joints 2, 3, 5; {self.plane.reach_area / 100:.0f} cm^2 reachable), "
            f"{self.meridian.revolved_blind_volume() / 1e6:.2f} litres in 3-D",
        ]
        out += [
            f"workpiece {f.face} face: {f.blind_area_mm2 / 100:.1f} of {f.area_mm2 / 100:.1f} cm^2 "
            f"unreachable ({100 * f.blind_fraction:.1f} %, {len(f.heights)} circles)"
            for f in self.faces
        ]
        return out


def _check_blind_zone_sizes(
    arm: SerialArm, pixel: float, samples: int, bands: int, seed: int, scan_step_mm: float = 8.0
) -> None:
    """Refuse, naming the option, what :func:`_blind_zones` could not do within the budget."""
    from armpath.workspace.blindzones import map_shape
    from armpath.workspace.sampling import check_count

    check_count(samples, "--samples", MAX_SAMPLES)
    check_size(
        3.0 * samples,
        MAX_SAMPLES,
        "joint samples (--samples for the arm plane, twice that for the meridian map)",
        "--samples",
    )
    check_count(bands, "--bands", MAX_BANDS, "circles a workpiece face", least=0)
    _check_seed(seed)
    _check_length(pixel, "pixel size", "--pixel")
    map_shape(arm, pixel, "--pixel")


def _blind_zones(
    arm: SerialArm,
    scene: Scene,
    pixel: float,
    samples: int,
    bands: int,
    seed: int,
    status: Callable[[str], None] | Any,
    scan_step_mm: float = 8.0,
) -> _BlindZones:
    """The maps and, with ``bands`` > 0, the faces. ``status`` takes the progress messages: a
    callback (as from :func:`~armpath.cli.common.progress`) or an object with ``update``."""
    from armpath.workspace.blindzones import arm_plane_map, meridian_map, surface_blindness

    say: Callable[[str], None] = status.update if hasattr(status, "update") else status
    _check_blind_zone_sizes(arm, pixel, samples, bands, seed, scan_step_mm)
    say("blind zones: sampling the arm plane ...")
    plane = arm_plane_map(arm, pixel, samples, seed=seed)
    say("blind zones: sampling the meridian map ...")
    meridian = meridian_map(arm, pixel, 2 * samples, seed=seed + 1)
    faces = (
        surface_blindness(
            arm,
            scene.world,
            _only_workpiece(scene),
            bands,
            scan_step_mm=scan_step_mm,
            resolution_mm=scan_step_mm / 16.0,
            progress=say,
        )
        if bands > 0
        else []
    )
    return _BlindZones(plane, meridian, faces, pixel)


def _write_blind_zones(folder: OutputFolder, bz: _BlindZones) -> None:
    from armpath.viz.workspace_figures import plot_blind_maps, plot_face_blindness

    rows = [
        f"{f.face},{z:.2f},{length:.2f},{blind:.2f}\n"
        for f in bz.faces
        for z, length, blind in zip(f.heights, f.length_mm, f.blind_mm, strict=True)
    ]
    folder.write_text(
        "blindzones.csv", "face,height_mm,circumference_mm,unreachable_mm\n" + "".join(rows)
    )
    np.savez_compressed(
        folder.file("blindzones.npz"),
        plane_reach=bz.plane.reach,
        plane_blind=bz.plane.blind,
        plane_origin_mm=bz.plane.origin,
        meridian_reach=bz.meridian.reach,
        meridian_blind=bz.meridian.blind,
        meridian_origin_mm=bz.meridian.origin,
        pixel_mm=bz.pixel,
    )
    plot_blind_maps(
        folder.file("blind_maps.png"),
        [(bz.plane, "arm plane (y, z)"), (bz.meridian, "about the axis (rho, z)")],
        "seed arm: reachable fingertip positions and enclosed blind zones",
    )
    if bz.faces:
        plot_face_blindness(
            folder.file("face_blindness.png"),
            bz.faces,
            "workpiece faces the fingertip cannot reach",
        )


@app.command()
def blindzones(
    pixel: Annotated[
        float,
        typer.Option(help=f"Pixel edge of the plane maps, mm (at most {MAX_GRID_CELLS:,} pixels)."),
    ] = 5.0,
    samples: Annotated[
        int,
        typer.Option(
            help="Joint samples of the arm-plane map (the 3-D meridian map: twice; at most "
            f"{MAX_SAMPLES:,} in all)."
        ),
    ] = 2_000_000,
    bands: Annotated[
        int,
        typer.Option(
            help="Horizontal circles per workpiece face (0: skip the faces; at most "
            f"{MAX_BANDS:,})."
        ),
    ] = 9,
    seed: Annotated[int, typer.Option(help="Random seed of the sampling.")] = 0,
    wall: WallOption = None,
    link_radius: LinkRadiusOption = None,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="Write blindzones.csv, blindzones.npz, blind_maps.png and face_blindness.png "
            "here.",
        ),
    ] = None,
    time_limit: TimeLimitOption = None,
) -> None:
    """Blind zones of the seed arm: the central blind zone in the arm plane and in 3-D (areas
    mm^2, volume mm^3), and the parts of the workpiece's outer and inner faces the fingertip
    cannot reach without a collision (areas mm^2, fractions)."""
    from armpath.export import output_folder

    with _cli_errors(time_limit):
        scene = _scene(None, wall)
        arm = _arm(0.0 if link_radius is None else link_radius)
        _check_blind_zone_sizes(arm, pixel, samples, bands, seed)
        folder_cm = output_folder(out) if out is not None else contextlib.nullcontext()
        with folder_cm as folder:
            with progress("blind zones ...") as say:
                bz = _blind_zones(arm, scene, pixel, samples, bands, seed, say)
            table = Table(title="blind zones of the seed arm", box=box.SIMPLE)
            for name in ("where", "blind", "of", "unit"):
                table.add_column(name)
            table.add_row(
                "arm plane (joints 2, 3, 5)",
                f"{bz.plane.blind_area:.0f}",
                f"{bz.plane.reach_area:.0f} reachable",
                "mm^2",
            )
            table.add_row(
                "3-D, about the vertical axis",
                f"{bz.meridian.revolved_blind_volume():.4g}",
                "",
                "mm^3",
            )
            for f in bz.faces:
                table.add_row(
                    f"workpiece {f.face} face",
                    f"{f.blind_area_mm2:.0f} ({100 * f.blind_fraction:.1f} %)",
                    f"{f.area_mm2:.0f}",
                    "mm^2",
                )
            out_console.print(table)
            wall_convention = scene.wall_thickness
            out_console.print(
                f"scene {scene.name}: wall thickness measured "
                f"{wall_convention.value if wall_convention else '-'}; {pixel:g} mm pixels; "
                f"faces by {bands} horizontal circles each",
                markup=False,
            )
            for warning in bz.warnings(pixel):
                err_console.print(warning, markup=False)
            if folder is not None:
                _write_blind_zones(folder, bz)
        if out is not None and folder is not None:
            print_written(folder)


#: The warnings filter (``-W``) that keeps the resource tracker of joblib's worker processes
#: quiet about the semaphores it removes at exit.
TRACKER_WARNINGS = "ignore::UserWarning:joblib.externals.loky.backend.resource_tracker"


def quiet_worker_tracker() -> None:
    """Keep the resource tracker that joblib's (loky's) worker processes share from writing
    to stderr. When the time limit stops the workers while one is still starting (a loaded
    machine takes seconds to start one), the semaphore made for it may be removed without the
    tracker being told; at exit the tracker then reports it as leaked and, removing it again,
    that it was gone: two warnings after the command's one ``error:`` line, about a clean-up
    that is the tracker's job and leaves nothing behind. The tracker is a process of its own,
    started with this process's warning options, so the filter goes there
    (:data:`TRACKER_WARNINGS`); before the first worker starts."""
    if TRACKER_WARNINGS not in sys.warnoptions:
        sys.warnoptions.append(TRACKER_WARNINGS)


@app.command("design-sweep")
def design_sweep(
    total: Annotated[
        float, typer.Option(help="Total link length AB + BC + CD + DE of every candidate, mm.")
    ] = 715.0,
    samples: Annotated[
        int,
        typer.Option(
            help=f"Joint samples per candidate (at most {MAX_SAMPLES:,} over the sweep and the "
            "seed arm)."
        ),
    ] = 1_000_000,
    pixel: Annotated[
        float,
        typer.Option(
            help=f"Pixel edge of the meridian maps, mm (at most {MAX_GRID_CELLS:,} pixels)."
        ),
    ] = 10.0,
    seed: Annotated[int, typer.Option(help="Random seed (every candidate uses it).")] = 0,
    jobs: Annotated[
        int,
        typer.Option(
            help=f"Local worker processes (-1: every core; at most {MAX_JOBS}; no more than "
            "the machine's cores are started)."
        ),
    ] = -1,
    scheduler: Annotated[
        str | None,
        typer.Option(help="Address of a Dask scheduler (e.g. tcp://host:8786) to run on."),
    ] = None,
    top: Annotated[int, typer.Option(help="Candidates listed, best first.")] = 10,
    out: Annotated[
        Path | None, typer.Option("--out", help="Write design_sweep.csv and design_sweep.png here.")
    ] = None,
    time_limit: TimeLimitOption = None,
) -> None:
    """Design study of the seed arm: link lengths (AB, BC = CD, DE at a fixed total) and the
    range of joint 3 against the reach volume above the table (m^3) and the central blind zone
    (litres). Objective: the largest reach volume; ties (within 0.5 %) go to the smaller blind
    zone. Under --time-limit the designs go out one per worker at a time."""
    from armpath.export import output_folder
    from armpath.model.seed_arm import SeedArmGeometry
    from armpath.workspace.design import (
        check_jobs,
        check_sweep_size,
        design_grid,
        evaluate_design,
        ranked,
        sweep,
    )
    from armpath.workspace.sampling import check_count

    with _cli_errors(time_limit):
        check_jobs(jobs, "--jobs")
        check_count(samples, "--samples", MAX_SAMPLES, "joint samples a design")
        if top < 1:
            raise InvalidInputError(f"--top must be >= 1, got {top}")
        _check_seed(seed)
        _check_length(total, "total length", "--total")
        _check_length(pixel, "pixel size", "--pixel")
        candidates = design_grid(total)
        check_sweep_size(
            candidates, pixel, samples, seed, extra=1, options=("--pixel or --total", "--samples")
        )
        folder_cm = output_folder(out) if out is not None else contextlib.nullcontext()
        quiet_worker_tracker()
        with folder_cm as folder:
            where = f"Dask at {scheduler}" if scheduler else "joblib on this machine"
            with progress(f"evaluating {len(candidates)} designs ({where}) ...") as say:
                results = ranked(
                    sweep(
                        candidates,
                        pixel_mm=pixel,
                        samples=samples,
                        seed=seed,
                        scheduler=scheduler,
                        n_jobs=jobs,
                    )
                )
                say("evaluating the seed arm ...")
                reference = evaluate_design(SeedArmGeometry(), pixel, samples, seed)
            columns = list(reference.row())
            shown = {
                "AB_mm": "AB mm",
                "BC_mm": "BC=CD mm",
                "DE_mm": "DE mm",
                "theta3_deg": "θ3 ±deg",
                "reach_volume_m3": "reach m^3",
                "blind_volume_l": "blind l",
                "nearest_to_B_mm": "nearest to B mm",
            }
            table = Table(
                title=f"seed-arm designs, total length {total:g} mm (best first)", box=box.SIMPLE
            )
            for name in ("#", *shown.values()):
                table.add_column(name, justify="right")

            def cells(r: dict[str, float]) -> list[str]:
                return [f"{r[k]:.4g}" for k in shown]

            for k, r in enumerate(results[:top]):
                table.add_row(str(k + 1), *cells(r.row()))
            table.add_row("seed", *cells(reference.row()))
            out_console.print(table)
            best = results[0]
            out_console.print(
                f"recommendation: AB {best.geometry.ab_mm:g}, BC = CD {best.geometry.bc_mm:g}, "
                f"DE {best.geometry.de_mm:g} mm, joint 3 within ±{best.geometry.range_deg[2]:g}°: "
                f"{best.reach_volume_mm3 / 1e9:.4f} m^3 above the table "
                f"({100 * (best.reach_volume_mm3 / reference.reach_volume_mm3 - 1):+.1f} % on the "
                f"seed arm), blind zone {best.blind_volume_mm3 / 1e6:.3g} l "
                f"(seed arm {reference.blind_volume_mm3 / 1e6:.3g} l)",
                markup=False,
            )
            unsettled = sum(not r.settled for r in [*results, reference])
            if unsettled:
                seed_too = " (the seed arm's among them)" if not reference.settled else ""
                err_console.print(
                    f"warning: the maps of {unsettled} of the {len(results) + 1} "
                    f"designs{seed_too} changed much over the second half of their "
                    f"{samples:,} samples (reachable or blind area): too few for {pixel:g} mm "
                    "pixels, and their blind volumes are not settled (more --samples or a "
                    "larger --pixel)",
                    markup=False,
                )
            if folder is not None:
                from armpath.viz.workspace_figures import plot_design_sweep

                folder.write_text(
                    "design_sweep.csv",
                    "rank,"
                    + ",".join(columns)
                    + "\n"
                    + "".join(
                        f"{k + 1}," + ",".join(f"{v:.6g}" for v in r.row().values()) + "\n"
                        for k, r in enumerate(results)
                    ),
                )
                plot_design_sweep(folder.file("design_sweep.png"), results, reference)
        if out is not None and folder is not None:
            print_written(folder)
