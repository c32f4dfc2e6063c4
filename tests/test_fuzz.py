"""Property-based fuzzing of every input a user hands yore: scene files, state files and API
arguments. Each property is "a result, or the documented error (one line) — never another
exception, never a crash". Sizes stay tiny (meshes of at most 5×5 vertices) and the examples
are derandomized, so the file runs the same in CI in a few tens of seconds."""

import io
import math
import zipfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import yore
from yore.runs import SceneError, load_scene, parse_override

FUZZ = settings(
    max_examples=200,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)

BASE_SCENE = {
    "mesh": {"generator": "grid", "nx": 4, "ny": 4, "width": 1.0, "height": 1.0},
    "material": {"mass": 0.1, "stretch_stiffness": 200.0},
    "fixed": [{"set": "top corners"}, {"indices": [0, 3]}],
    "simulation": {"integrator": "implicit", "duration": 0.05, "dt": 0.01},
    "integrator": {"max_newton": 5, "linearized": False},
    "strokes": [
        {
            "time": 0.0,
            "material": [[0.2, 0.5], [0.8, 0.5]],
            "smooth": {"iterations": 2, "strength": 0.5, "region": "all"},
        }
    ],
    "camera": {"width": 64, "height": 48},
    "output": {"format": "none", "pictures": False},
}

# -- a small TOML writer (tomllib only reads) ---------------------------------------------------


def toml_value(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f'"{k}" = {toml_value(v)}' for k, v in value.items()) + "}"
    raise TypeError(type(value))


def toml_document(scene):
    lines = []
    for name, table in scene.items():
        if isinstance(table, list) and all(isinstance(t, dict) for t in table) and table:
            for entry in table:
                lines.append(f"[[{name}]]")
                lines += [f'"{k}" = {toml_value(v)}' for k, v in entry.items()]
        elif isinstance(table, dict):
            lines.append(f"[{name}]")
            lines += [f'"{k}" = {toml_value(v)}' for k, v in table.items()]
        else:
            lines.insert(0, f'"{name}" = {toml_value(table)}')
    return "\n".join(lines) + "\n"


scalars = st.one_of(
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.sampled_from([0, 1, 2, 5, 2**31, 2**63 - 1]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -1.0, 1e9, 1e-300]),
    st.text(max_size=8),
    st.sampled_from(["all", "stroke", "grid", "cylinder", "explicit"]),
)
values = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=5), inner, max_size=3)
    ),
    max_leaves=12,
)
keys = st.one_of(
    st.sampled_from(
        [
            "nx",
            "ny",
            "generator",
            "indices",
            "set",
            "time",
            "material",
            "points",
            "screen",
            "width",
            "height",
            "iterations",
            "strength",
            "region",
            "max_newton",
            "solver",
            "dt",
            "duration",
            "fps",
            "every_steps",
            "box",
            "smooth",
            "mass",
        ]
    ),
    st.text(min_size=1, max_size=6),
)


@st.composite
def mutated_scenes(draw):
    scene = {
        name: (dict(table) if isinstance(table, dict) else [dict(t) for t in table])
        for name, table in BASE_SCENE.items()
    }
    for _ in range(draw(st.integers(1, 4))):
        name = draw(st.sampled_from(sorted(scene) + ["scene", "driven", "bogus"]))
        action = draw(st.sampled_from(["set", "delete", "replace table", "nest"]))
        table = scene.get(name)
        if action == "replace table" or table is None:
            scene[name] = draw(values)
        elif action == "delete":
            del scene[name]
        else:
            target = table[0] if isinstance(table, list) and table else table
            if not isinstance(target, dict):
                scene[name] = draw(values)
                continue
            value = draw(values)
            if action == "nest":
                for _ in range(draw(st.integers(1, 40))):
                    value = [value]
            target[draw(keys)] = value
    return scene


def loaded_or_scene_error(text, overrides=None):
    try:
        scene = load_scene(text=text, overrides=overrides)
    except SceneError as error:
        assert "\n" not in str(error)
        return None
    return scene


@pytest.mark.slow
@FUZZ
@given(mutated_scenes())
def test_a_mutated_scene_file_loads_or_is_a_scene_error(scene):
    loaded = loaded_or_scene_error(toml_document(scene))
    if (
        loaded is not None
        and loaded.data["mesh"]["generator"] == "grid"
        and loaded.data["mesh"]["nx"] * loaded.data["mesh"]["ny"] <= 25
    ):
        try:
            sim, _ = loaded.build()
            loaded.check_strokes(sim)
        except SceneError as error:
            assert "\n" not in str(error)


@FUZZ
@given(st.text(max_size=200))
def test_any_text_is_a_scene_or_a_scene_error(text):
    loaded_or_scene_error(text)


@FUZZ
@given(
    st.sampled_from(
        [
            "mesh.nx",
            "camera.width",
            "strokes.0.time",
            "integrator.max_newton",
            "fixed.1.indices",
            "simulation.dt",
            "mesh",
            "a.b.c",
            "strokes.9.time",
        ]
    ),
    st.one_of(
        st.text(max_size=30),
        st.integers(0, 1200).map(lambda d: "[" * d + "]" * d),
        st.integers(0, 1200).map(lambda d: "{a=" * d + "1" + "}" * d),
    ),
)
def test_a_set_override_is_parsed_and_checked_or_is_a_value_error(key, value):
    try:
        parsed_key, parsed = parse_override(f"{key}={value}")
    except ValueError as error:
        assert "\n" not in str(error)
        return
    loaded_or_scene_error(toml_document(BASE_SCENE), {parsed_key: parsed})


# -- state files --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def state_bytes(tmp_path_factory):
    V, F = yore.grid_mesh(3, 3)
    cloth = yore.Cloth(V, F, masses=0.01)
    cloth.fix([0, 2])
    sim = yore.Simulation(cloth, integrator="bdf2", dt=0.01)
    sim.step(2)
    path = tmp_path_factory.mktemp("state") / "state.npz"
    yore.save_state(path, sim, metadata={"step": 2})
    return path.read_bytes()


def load_or_value_error(tmp_path, data, name="tampered.npz"):
    path = tmp_path / name
    path.write_bytes(data)
    try:
        sim, _ = yore.load_state(path)
    except ValueError as error:
        assert "\n" not in str(error) and str(path) in str(error)
        return None
    try:
        sim.step(1)  # a state that loads must also run, or stop with a documented error
    except (yore.SimulationDiverged, yore.NotPositiveDefinite) as error:
        # e.g. a tampered dt of 6.4e6 s: the step's matrix does not factor; one line that says so
        assert "\n" not in str(error) and "dt" in str(error)
    return sim


@pytest.mark.slow
@FUZZ
@given(st.data())
def test_a_state_file_with_flipped_or_cut_bytes_loads_or_is_a_value_error(
    tmp_path_factory, state_bytes, data
):
    tmp_path = tmp_path_factory.mktemp("flip")
    raw = bytearray(state_bytes)
    how = data.draw(st.sampled_from(["flip", "truncate", "splice"]))
    if how == "flip":
        for _ in range(data.draw(st.integers(1, 8))):
            raw[data.draw(st.integers(0, len(raw) - 1))] ^= data.draw(st.integers(1, 255))
    elif how == "truncate":
        raw = raw[: data.draw(st.integers(0, len(raw) - 1))]
    else:
        at = data.draw(st.integers(0, len(raw)))
        raw[at:at] = data.draw(st.binary(max_size=16))
    try:
        load_or_value_error(tmp_path, bytes(raw))
    except yore.SimulationDiverged:
        pass


def changed(state_bytes, change):
    """The arrays and JSON document of a state file after ``change(arrays, document)``."""
    import json

    with np.load(io.BytesIO(state_bytes), allow_pickle=False) as archive:
        arrays = {name: archive[name] for name in archive.files}
    document = json.loads(str(arrays.pop("__document__")))
    change(arrays, document)
    return arrays, document


def rewrite(state_bytes, change):
    """A state file whose arrays and JSON document went through ``change(arrays, document)``."""
    import json

    arrays, document = changed(state_bytes, change)
    out = io.BytesIO()
    np.savez(out, **arrays, __document__=np.array(json.dumps(document)))
    return out.getvalue()


array_names = st.sampled_from(
    [
        "simulation/cloth/positions",
        "simulation/cloth/velocities",
        "simulation/cloth/masses",
        "simulation/cloth/faces",
        "simulation/cloth/spring_ends",
        "simulation/cloth/spring_rest",
        "simulation/cloth/spring_kind",
        "simulation/cloth/vertex_states",
        "simulation/gravity",
        "simulation/history/positions",
    ]
)
replacement_arrays = st.one_of(
    st.sampled_from(
        [
            np.zeros(0),
            np.full((9, 3), np.nan),
            np.full(9, -1.0),
            np.full((24, 2), 9, dtype=np.int32),
            np.zeros((9, 3), dtype=np.float32),
            np.full(9, 1e-320),
            np.array([2**31 - 1, 0], dtype=np.int64),
            np.zeros((2, 2, 2)),
            np.array("text"),
            np.full(24, 7, dtype=np.int8),
        ]
    ),
    st.integers(-3, 3).map(lambda k: np.full((9, 3), k, dtype=np.int32)),
)
json_fields = st.sampled_from(
    [
        ("simulation", "dt"),
        ("simulation", "integrator"),
        ("simulation", "options"),
        ("simulation", "options", "max_newton"),
        ("simulation", "options", "linearized"),
        ("simulation", "target_time"),
        ("simulation", "cloth", "drag"),
        ("simulation", "cloth", "clock_steps"),
        ("simulation", "cloth", "drivers"),
        ("simulation", "history"),
        ("simulation", "history", "dt"),
        ("version",),
        ("format",),
        ("metadata",),
        ("simulation", "cloth", "positions"),
    ]
)


@pytest.mark.slow
@FUZZ
@given(st.data())
def test_a_state_file_with_tampered_fields_loads_or_is_a_value_error(
    tmp_path_factory, state_bytes, data
):
    tmp_path = tmp_path_factory.mktemp("tamper")
    if data.draw(st.booleans()):
        name, array = data.draw(array_names), data.draw(replacement_arrays)

        def change(arrays, document):
            arrays[name] = array
    else:
        path, value = data.draw(json_fields), data.draw(values)

        def change(arrays, document):
            node = document
            for part in path[:-1]:
                node = node[part]
            node[path[-1]] = value

    try:
        load_or_value_error(tmp_path, rewrite(state_bytes, change))
    except yore.SimulationDiverged:
        pass


def test_a_state_file_with_a_pickled_object_array_is_refused(tmp_path, state_bytes):
    def change(arrays, document):
        arrays["simulation/cloth/masses"] = np.array([{"x": 1}] * 9, dtype=object)

    data = rewrite_with_pickle(state_bytes, change)
    assert load_or_value_error(tmp_path, data) is None


def rewrite_with_pickle(state_bytes, change):
    import json

    arrays, document = changed(state_bytes, change)
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as archive:
        for name, array in {**arrays, "__document__": np.array(json.dumps(document))}.items():
            buffer = io.BytesIO()
            np.save(buffer, array, allow_pickle=True)
            archive.writestr(name + ".npy", buffer.getvalue())
    return out.getvalue()


# -- API arguments ------------------------------------------------------------------------------

any_argument = st.one_of(
    values,
    st.sampled_from(
        [np.float64(0.5), np.int64(3), np.bool_(True), float("inf"), float("nan"), None, "no"]
    ),
)
OPTION_NAMES = {
    integrator: sorted(yore.simulation.INTEGRATOR_OPTIONS[integrator])
    for integrator in ("explicit", "implicit", "local-global")
}


@pytest.fixture(scope="module")
def small_cloth_state():
    V, F = yore.grid_mesh(4, 4)
    cloth = yore.Cloth(V, F, masses=0.01)
    cloth.fix([12, 15])
    return cloth.state()


@pytest.mark.slow
@FUZZ
@given(st.sampled_from(sorted(OPTION_NAMES)), st.data())
def test_simulation_options_are_accepted_as_given_or_are_value_errors(
    small_cloth_state, integrator, data
):
    name = data.draw(st.sampled_from(OPTION_NAMES[integrator]))
    value = data.draw(any_argument)
    cloth = yore.Cloth.from_state(small_cloth_state)
    try:
        sim = yore.Simulation(cloth, integrator=integrator, dt=1e-3, **{name: value})
    except ValueError as error:
        assert "\n" not in str(error) and name in str(error)
        return
    stored = sim.state()["options"][name]
    if value is None:
        # "decide from the others": a state stores what ran, the decision for the other
        # options' defaults (e.g. mixed=None runs the mixed matrices with the clamp)
        assert stored == yore.options.defaults(integrator)[name]
        return
    # Accepted means accepted as given: no bool for a count, no rounding, no string for a flag.
    assert stored == value and type(stored) in (type(value), float, int, bool, type(None))
    assert not isinstance(value, str) or isinstance(stored, str)


@pytest.mark.slow
@FUZZ
@given(any_argument, any_argument, st.one_of(any_argument, st.lists(st.integers(-2, 20))))
def test_smooth_rest_lengths_arguments_are_checked(small_cloth_state, iterations, strength, region):
    sim = yore.Simulation(yore.Cloth.from_state(small_cloth_state), dt=1e-3)
    try:
        result = sim.smooth_rest_lengths(iterations=iterations, strength=strength, region=region)
    except ValueError as error:
        assert "\n" not in str(error)
        return
    assert isinstance(iterations, (int, np.integer)) and not isinstance(iterations, bool)
    assert 0 <= iterations and 0 < strength <= 1
    assert result["springs"] >= 0


@pytest.mark.slow
@FUZZ
@given(any_argument, any_argument, any_argument, any_argument)
def test_grid_mesh_and_cloth_arguments_are_checked(nx, ny, mass, stiffness):
    try:
        V, F = yore.grid_mesh(nx, ny)
    except (ValueError, TypeError) as error:
        assert "\n" not in str(error)
        return
    assert len(V) == nx * ny <= yore.meshes.MAX_MESH_VERTICES
    if len(V) > 25:
        return
    try:
        yore.Cloth(V, F, masses=mass, stretch_stiffness=stiffness)
    except ValueError as error:
        assert "\n" not in str(error)
    except TypeError:
        # pybind11 refuses a non-number for a float parameter with its own (multi-line)
        # TypeError, which is the documented kind of error for a wrong type.
        assert not isinstance(stiffness, (int, float)) or isinstance(stiffness, bool)


@FUZZ
@given(any_argument, any_argument)
def test_camera_sizes_are_checked_before_allocating(width, height):
    try:
        camera = yore.Camera(
            eye=(0.5, 0.5, 3.0), target=(0.5, 0.5, 0.0), width=width, height=height
        )
    except ValueError as error:
        assert "\n" not in str(error)
        return
    assert camera.width * camera.height <= yore.checks.MAX_IMAGE_PIXELS


# -- sweep files, sweep records, stroke options (issue 22) ------------------------------------
BASE_SWEEP = {
    "sweep": {"scene": "hanging", "repeats": 1},
    "axes": {"material.stretch_stiffness": [100.0, 200.0]},
    "zip": {"step": {"simulation.dt": [1e-3, 2e-3], "simulation.duration": [1.0, 2.0]}},
    "record": {"frames": False},
}


@st.composite
def mutated_sweeps(draw):
    sweep = {name: dict(table) for name, table in BASE_SWEEP.items()}
    for _ in range(draw(st.integers(1, 3))):
        name = draw(st.sampled_from(sorted(sweep) + ["bogus"]))
        action = draw(st.sampled_from(["set", "delete", "replace table"]))
        if action == "delete" and name in sweep:
            del sweep[name]
        elif action == "replace table" or not isinstance(sweep.get(name), dict):
            sweep[name] = draw(values)
        else:
            sweep[name][
                draw(
                    st.one_of(
                        keys,
                        st.sampled_from(
                            [
                                "scene",
                                "repeats",
                                "set",
                                "status",
                                "message",
                                "a/b",
                                "",
                                ".",
                                "mesh.nx",
                                "simulation.dt",
                                "reference",
                            ]
                        ),
                    )
                )
            ] = draw(values)
    return sweep


@pytest.mark.slow
@FUZZ
@given(mutated_sweeps())
def test_a_mutated_sweep_file_loads_or_is_a_sweep_error(tmp_path_factory, sweep):
    from yore.sweep import SweepError, load_sweep

    folder = tmp_path_factory.mktemp("sweep")
    path = folder / "sweep.toml"
    path.write_text(toml_document(sweep))
    try:
        loaded = load_sweep(path, check_cells=False)
    except SweepError as error:
        assert "\n" not in str(error)
        return
    assert loaded.cell_count >= 1


@pytest.fixture(scope="module")
def sweep_and_cell(tmp_path_factory):
    from yore.sweep import load_sweep

    folder = tmp_path_factory.mktemp("records")
    path = folder / "sweep.toml"
    path.write_text(toml_document(BASE_SWEEP))
    sweep = load_sweep(path, check_cells=False)
    return sweep, next(sweep.cells())


@pytest.mark.slow
@FUZZ
@given(
    st.one_of(
        values,
        st.fixed_dictionaries(
            {
                "status": st.one_of(st.sampled_from(["done", "failed"]), values),
                "message": values,
                "overrides": values,
                "values": values,
            }
        ),
    )
)
def test_a_tampered_cell_record_is_read_or_is_a_value_error(
    tmp_path_factory, sweep_and_cell, record
):
    import json

    from yore.sweep.results import read_record

    sweep, cell = sweep_and_cell
    path = tmp_path_factory.mktemp("record") / "000000.json"
    try:
        path.write_text(json.dumps(record))
    except ValueError:  # nan/inf are not JSON: write them as Python's json does
        path.write_text(json.dumps(record, allow_nan=True))
    try:
        read = read_record(path, cell)
    except ValueError as error:
        assert "\n" not in str(error) and "000000.json" in str(error)
        return
    assert read["overrides"] == json.loads(json.dumps(cell.overrides, default=str))
    assert all(math.isfinite(v) for v in read["values"].values())


@pytest.mark.slow
@FUZZ
@given(any_argument, any_argument, any_argument, any_argument, any_argument)
def test_stroke_options_are_accepted_or_are_value_errors(
    small_cloth_state, expansion, mass_scale, width, growth, refine
):
    cloth = yore.Cloth.from_state(small_cloth_state)
    V, _ = yore.grid_mesh(4, 4)
    cloth.material_coordinates = V[:, :2]
    sim = yore.Simulation(cloth, dt=1e-3)
    try:
        sim.stroke(
            yore.StrokePath.material([[0.1, 0.5], [0.9, 0.5]]),
            expansion=expansion,
            mass_scale=mass_scale,
            width=width,
            growth=growth,
            refine=refine,
        )
    except ValueError as error:
        assert "\n" not in str(error)
        return
    assert np.all(np.isfinite(sim.cloth.positions)) and np.all(sim.cloth.springs.rest > 0)
