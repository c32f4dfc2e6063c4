"""The typed boundary: what crosses between C++ and Python is a bound class with read-only
fields named as in C++ (a stroke's result, an integrator's statistics), not a dict rebuilt on
each side."""

import re
from pathlib import Path

import numpy as np
import pytest

import yore
from yore import _core
from yore.stroke import CORE_FIELDS, StrokePath

ROOT = Path(__file__).resolve().parents[1]


def _struct_fields(header, struct):
    """Member names of a C++ struct, read from its header (``type name = ...;``/``type name;``)."""
    text = (ROOT / "cpp" / "include" / "yore" / header).read_text(encoding="utf-8")
    body = re.search(rf"struct {struct} {{(.*?)\n}};", text, re.S).group(1)
    return set(re.findall(r"^\s+[\w:<>, ]+?\s(\w+)(?: = [^;]+)?;", body, re.M))


def test_a_reports_core_fields_are_the_structs_by_the_same_names():
    fields = _struct_fields("stroke/stroke_pipeline.hpp", "StrokeResult")
    assert {"faces_split", "faces_skipped", "rest_length_added", "line_vertices"} <= fields
    # every field of the struct is bound under its own name; vertices_added is derived
    # (the count of new_vertices) and the only name C++ does not hold
    assert set(CORE_FIELDS) == fields | {"vertices_added"}


def test_a_stroke_result_is_read_only():
    sim = yore.scenes.hanging_cloth(resolution=7)
    report = sim.stroke(StrokePath.material([[0.2, 0.6], [0.8, 0.6]]))
    with pytest.raises(AttributeError):
        report.faces_split = 3
    for name in ("faces_skipped", "region_faces", "new_vertices", "line_vertices"):
        array = getattr(report, name)
        assert isinstance(array, np.ndarray) and not array.flags.writeable, name
    assert report.vertices_added == len(report.new_vertices) > 0
    with pytest.raises(AttributeError, match="no attribute 'faces_crossed'"):
        report.faces_crossed  # noqa: B018 - a name neither side has
    # the Python side's own fields stay writable: the next step fills in the re-analysis
    assert report.reanalyze_seconds is None
    sim.step()
    assert report.reanalyze_seconds == 0.0  # explicit: nothing to re-analyse


@pytest.mark.parametrize("integrator", ["explicit", "implicit", "local-global", "cvode"])
def test_statistics_name_each_phase_and_counter_once(integrator):
    sim = yore.scenes.hanging_cloth(resolution=5, integrator=integrator)
    sim.step(3)
    statistics = sim._integrator.statistics
    assert isinstance(statistics, _core.Statistics)
    assert statistics.steps == 3
    assert statistics.phases and all(name.endswith("_seconds") for name in statistics.phases)
    assert not any(name.endswith("_seconds") for name in statistics.counters)
    assert not set(statistics.phases) & set(statistics.counters)
    assert all(value >= 0.0 for value in statistics.phases.values())
    with pytest.raises(AttributeError):
        statistics.steps = 0
    statistics.phases.clear()  # a copy: the integrator's own are untouched
    assert sim._integrator.statistics.phases
    stats = sim.stats
    assert stats["steps"] == 3
    assert list(stats["phases"]) == list(sim._integrator.statistics.phases)
    assert list(stats["counters"]) == list(sim._integrator.statistics.counters)


@pytest.mark.parametrize("integrator", sorted(yore.options.INTEGRATORS))
def test_an_integrators_options_cross_as_a_read_only_struct(integrator):
    # the registry's factory turns the resolved options into the C++ struct: read back as a
    # bound class, every core option the row passes is the value the Simulation resolved
    sim = yore.scenes.hanging_cloth(resolution=5, integrator=integrator)
    options = sim._integrator.options
    assert type(options).__name__.endswith("Options")
    core = type(sim._integrator).defaults
    resolved = sim.resolved_options
    shared = [name for name in resolved if name in core and resolved[name] is not None]
    assert shared  # every integrator hands some of its options to the core
    for name in shared:
        value = getattr(options, name)
        if name == "chebyshev_rho" and resolved.get("acceleration") == "none":
            assert value == 0.0
        else:
            assert value == resolved[name], name
    with pytest.raises(AttributeError):
        setattr(options, shared[0], resolved[shared[0]])
    assert repr(options).startswith(type(options).__name__ + "(")


@pytest.mark.parametrize(
    "given, expected",
    [
        # nothing given: the clamp with the mixed matrices, Newton from the inertial guess
        ({}, ("clamp", "inertial", True)),
        # the linearized step: its start, and no mixed matrices (one step is the same either way)
        ({"linearized": True}, ("clamp", "start", False)),
        ({"adaptive_projection": True}, ("exact", "inertial", False)),
        ({"adaptive_projection": False}, ("clamp", "inertial", True)),
        ({"projection": "steihaug"}, ("steihaug", "inertial", False)),
        ({"projection": "exact", "adaptive_projection": True}, ("exact", "inertial", False)),
        ({"projection": "clamp", "mixed": False, "predictor": "start"}, ("clamp", "start", False)),
    ],
)
def test_the_core_decides_the_open_choices(given, expected):
    # None (or absent) is "decide from the others", a std::optional in C++: one place decides
    options = {
        "adaptive_projection": None,
        "projection": None,
        "predictor": None,
        "mixed": None,
        **given,
    }
    decided = _core.ImplicitIntegrator.resolve_choices(options)
    assert (decided["projection"], decided["predictor"], decided["mixed"]) == expected
    # and yore.options.resolve_options is that decision
    resolved = yore.options.resolve_options(
        "implicit", {**yore.options.INTEGRATOR_OPTIONS["implicit"], **given}
    )
    assert (resolved["projection"], resolved["predictor"], resolved["mixed"]) == expected


def test_contradicting_choices_are_refused_and_quasi_newton_decides_only_its_predictor():
    with pytest.raises(
        ValueError,
        match="adaptive_projection=True contradicts projection='clamp'; give one of them",
    ):
        _core.ImplicitIntegrator.resolve_choices(
            {"adaptive_projection": True, "projection": "clamp"}
        )
    resolved = yore.options.resolve_options(
        "quasi-newton", dict(yore.options.INTEGRATOR_OPTIONS["quasi-newton"], predictor=None)
    )
    assert resolved["predictor"] == "inertial" and "projection" not in resolved
    explicit = yore.options.INTEGRATOR_OPTIONS["explicit"]
    assert yore.options.resolve_options("explicit", explicit) == explicit


def _same_fields(result, kind):
    """``result`` is the typed result ``kind``: it holds exactly the declared fields, and each
    reads the same by attribute and by key."""
    assert type(result) is kind
    assert set(result) == set(kind.fields_), set(result) ^ set(kind.fields_)
    for name in kind.fields_:
        assert getattr(result, name) is result[name], name


def test_the_cloths_reports_are_typed_results():
    from yore.results import ClothState, Energy, MembraneStatus, QuadraticBending

    sim = yore.scenes.hanging_cloth(
        resolution=6,
        stretch="membrane",
        young_modulus=1e3,
        bending="quadratic",
        bending_modulus=1e-4,
    )
    cloth = sim.cloth
    state = cloth.state()
    _same_fields(state, ClothState)
    assert yore.Cloth.from_state(state).state().positions.tobytes() == state.positions.tobytes()
    energy = cloth.energy([0.0, 0.0, -9.81])
    _same_fields(energy, Energy)
    parts = energy.kinetic + energy.spring + energy.gravity + energy.bending + energy.membrane
    assert energy.total == pytest.approx(parts, rel=1e-15)
    status = cloth.membrane_status()
    _same_fields(status, MembraneStatus)
    assert status.rest_area == pytest.approx(1.0, rel=1e-12)  # the 1 m square at rest
    bending = cloth.quadratic_bending
    _same_fields(bending, QuadraticBending)
    # a 6×6 grid of two triangles per cell has 3·25 + 10 - 20 = 65 interior edges
    assert bending.hinges == 65 and bending.size == cloth.vertex_count
    from yore.results import NewtonSystem

    system = _core.ImplicitIntegrator().newton_system(
        cloth, [0.0, -9.81, 0.0], 1 / 60, cloth.positions
    )
    _same_fields(system, NewtonSystem)
    assert len(system.gradient) == 3 * len(system.free_vertices) == system.size


def test_the_mesh_queries_return_typed_results():
    from yore.results import FaceRefinement, FaceSplit, RayHits
    from yore.subdivision import refine_faces_1to4, split_faces_1to3

    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    F = np.array([[0, 1, 2], [1, 3, 2]], dtype=np.int32)
    split = split_faces_1to3(V, F, [0])
    _same_fields(split, FaceSplit)
    assert len(split.faces) == 4 and len(split.vertices) == 5
    refined = refine_faces_1to4(V, F, [0])
    _same_fields(refined, FaceRefinement)
    assert len(refined.split_edges) == 3  # face 0's edges; face 1 is bisected on the shared one
    sim = yore.scenes.hanging_cloth(resolution=5)
    hits = _core.pick_rays(
        sim.cloth,
        np.array([[0.0, 0.0, 0.0]]),
        np.array([0.5, 0.5, 5.0]),  # above the hanging square's middle, looking down -z
        np.array([0.0, 0.0, -1.0]),
        np.zeros(3),
        np.zeros(3),
    )
    _same_fields(hits, RayHits)
