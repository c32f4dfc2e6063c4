"""Saving and restoring: Cloth.state / from_state, pickle, state files, and bit-exact resume."""

import os
import pickle
import re

import numpy as np
import pytest

import yore


def stroked_hanging(integrator="explicit", **options):
    sim = yore.scenes.hanging_cloth(resolution=9, integrator=integrator, **options)
    sim.step(5)
    sim.stroke(yore.StrokePath.material([[0.2, 0.3], [0.8, 0.45]]))
    return sim


def assert_same_state(a, b):
    assert a.keys() == b.keys()
    for key in a:
        if key == "drivers":
            assert len(a[key]) == len(b[key])
            for da, db in zip(a[key], b[key]):
                for name in da:
                    assert np.array_equal(da[name], db[name]), f"driver {name}"
        elif isinstance(a[key], np.ndarray):
            assert a[key].dtype == b[key].dtype, key
            assert np.array_equal(a[key], b[key]), key
        else:
            assert a[key] == b[key], key


def test_cloth_state_round_trips_exactly_after_a_stroke_and_with_drivers():
    for sim in (stroked_hanging(), yore.scenes.rotating_cylinder(rings=5, segments=8)):
        sim.step(3)
        state = sim.cloth.state()
        copy = yore.Cloth.from_state(state)
        assert_same_state(state, copy.state())
        assert copy.topology_version != sim.cloth.topology_version  # caches cannot mix them up
        assert_same_state(state, pickle.loads(pickle.dumps(sim.cloth)).state())


def test_clock_does_not_depend_on_how_a_run_is_split():
    # origin + steps × dt: the same bits whether 100 steps come as one call or as 37 + 63.
    a = yore.scenes.rotating_cylinder(rings=5, segments=8)
    b = yore.scenes.rotating_cylinder(rings=5, segments=8)
    a.step(100)
    b.step(37)
    b.step(63)
    assert a.time == b.time == 100 * a.dt
    assert np.array_equal(a.cloth.positions, b.cloth.positions)


@pytest.mark.parametrize(
    "integrator", ["explicit", "implicit", "bdf2", "generalized-alpha", "tr-bdf2", "local-global"]
)
def test_a_restored_simulation_continues_bit_for_bit(tmp_path, integrator):
    # local-global's buckling start needs more than its default 300 iterations per step
    options = {"iterations": 2000} if integrator == "local-global" else {}
    straight = stroked_hanging(integrator, **options)
    resumed = stroked_hanging(integrator, **options)
    straight.step(12)
    resumed.step(5)
    path = yore.save_state(tmp_path / "state.npz", resumed, metadata={"note": [1, 2.5]})
    del resumed
    restored, metadata = yore.load_state(path)
    assert metadata == {"note": [1, 2.5]}
    assert restored.integrator == integrator
    assert restored.resolved_options == straight.resolved_options
    restored.step(7)
    assert restored.time == straight.time
    assert np.array_equal(restored.cloth.positions, straight.cloth.positions)
    assert np.array_equal(restored.cloth.velocities, straight.cloth.velocities)


def test_bdf2_history_is_what_makes_the_resume_exact():
    # Without its one-step history BDF2 restarts with a backward-Euler step: a different result.
    straight = stroked_hanging("bdf2")
    straight.step(8)
    sim = stroked_hanging("bdf2")
    sim.step(4)
    state = sim.state()
    assert state["history"] is not None
    state["history"] = None
    forgetful = yore.Simulation.from_state(state)
    forgetful.step(4)
    assert not np.array_equal(forgetful.cloth.positions, straight.cloth.positions)


def test_bad_states_and_files_are_value_errors_naming_the_problem(tmp_path):
    state = stroked_hanging().cloth.state()
    with pytest.raises(ValueError, match="unknown key"):
        yore.Cloth.from_state({**state, "colour": 1})
    with pytest.raises(ValueError, match="missing key.*masses"):
        yore.Cloth.from_state({k: v for k, v in state.items() if k != "masses"})
    ends = state["spring_ends"].copy()
    ends[3, 1] = 10_000
    with pytest.raises(ValueError, match="spring 3"):
        yore.Cloth.from_state({**state, "spring_ends": ends})
    rest = state["spring_rest"].copy()
    rest[2] = np.nan
    with pytest.raises(ValueError, match="spring 2"):
        yore.Cloth.from_state({**state, "spring_rest": rest})
    vertex_states = state["vertex_states"].copy()
    vertex_states[4] = 2  # driven, but no driver moves it
    with pytest.raises(ValueError, match="vertex 4"):
        yore.Cloth.from_state({**state, "vertex_states": vertex_states})
    with pytest.raises(ValueError, match="does not exist"):
        yore.load_state(tmp_path / "missing.npz")
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(ValueError, match="not a yore state"):
        yore.load_state(tmp_path / "other.npz")
    with pytest.raises(ValueError, match="JSON"):
        yore.save_state(tmp_path / "s.npz", stroked_hanging(), metadata={"f": object()})


# -- a state file is checked field by field before the core sees it ---------------------------


@pytest.fixture
def state_file(tmp_path):
    sim = yore.Simulation(yore.Cloth(*yore.grid_mesh(3, 3), masses=0.01), integrator="bdf2")
    sim.step(2)
    return yore.save_state(tmp_path / "state.npz", sim, metadata={"step": 2})


def tampered(path, change):
    import json

    with np.load(path, allow_pickle=False) as archive:
        arrays = {name: archive[name] for name in archive.files}
    document = json.loads(str(arrays.pop("__document__")))
    change(arrays, document)
    np.savez(path, **arrays, __document__=np.array(json.dumps(document)))
    return path


def one_line_error(path, match):
    with pytest.raises(ValueError, match=match) as caught:
        yore.load_state(path)
    assert "\n" not in str(caught.value) and str(path) in str(caught.value)


@pytest.mark.parametrize("keep", [0.1, 0.5, 0.9, 0.999])
def test_a_truncated_state_file_is_one_value_error(state_file, keep):
    data = state_file.read_bytes()
    state_file.write_bytes(data[: int(len(data) * keep)])
    one_line_error(state_file, "not a readable yore state file")


def test_a_corrupted_state_file_is_one_value_error(state_file):
    data = bytearray(state_file.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 8] = b"\xff" * 8  # inside an array: the CRC no longer matches
    state_file.write_bytes(bytes(data))
    one_line_error(state_file, "not a readable yore state file")


def test_a_state_document_that_is_not_json_is_named(state_file):
    def change(arrays, document):
        document.clear()

    tampered(state_file, change)
    one_line_error(state_file, "field document")


@pytest.mark.parametrize(
    "field, value, match",
    [
        ("spring_ends", np.array([[0, 99]] * 24, dtype=np.int32), "spring_ends: entry .* is 99"),
        ("masses", np.full(9, -1.0), "masses: entry 0 is -1.0"),
        ("masses", np.full(9, 1e-320), "masses: entry 0 is"),
        ("positions", np.full((9, 3), np.nan), "positions: entry .* is nan"),
        (
            "positions",
            np.zeros((9, 3), dtype=np.float32),
            "positions: got an array of dtype float32",
        ),
        ("faces", np.full((8, 3), 2**31 - 1, dtype=np.int32), "faces: entry .* is 2147483647"),
        # refused from its header, before it is read (issue 53, N09)
        (
            "velocities",
            np.zeros((4, 3)),
            "velocities: its header declares 4 rows where the positions declare 9 vertices",
        ),
        ("spring_kind", np.full(24, 7, dtype=np.int8), "spring_kind: entry 0 is 7"),
    ],
)
def test_a_tampered_cloth_array_is_named(state_file, field, value, match):
    tampered(
        state_file, lambda arrays, document: arrays.__setitem__(f"simulation/cloth/{field}", value)
    )
    one_line_error(state_file, f"field simulation.cloth.{match}")


@pytest.mark.parametrize(
    "path, value, match",
    [
        (("simulation", "options", "max_newton"), 2.9, "options.max_newton"),
        (("simulation", "options", "linearized"), "no", "options.linearized"),
        (("simulation", "dt"), -1.0, "simulation.dt"),
        (("simulation", "integrator"), "rk4", "simulation.integrator"),
        (("simulation", "cloth", "clock_steps"), 2**70, "clock_steps"),
        (("simulation", "cloth", "drivers"), [{"vertices": 1}], r"drivers\[0\]"),
        (("simulation", "cloth", "positions"), {"$array": "nowhere"}, "missing array"),
        (("version",), 2, "field version"),
    ],
)
def test_a_tampered_document_field_is_named(state_file, path, value, match):
    def change(arrays, document):
        node = document
        for part in path[:-1]:
            node = node[part]
        node[path[-1]] = value

    tampered(state_file, change)
    one_line_error(state_file, match)


def test_a_pickled_object_array_is_never_loaded(state_file):
    import zipfile

    with zipfile.ZipFile(state_file, "a") as archive:
        import io as _io

        buffer = _io.BytesIO()
        np.save(buffer, np.array([object()], dtype=object), allow_pickle=True)
        archive.writestr("evil.npy", buffer.getvalue())
    # a member the document does not refer to is refused unread
    one_line_error(state_file, "member evil.npy is not a field the state refers to")


def test_a_pickled_array_the_document_refers_to_is_never_loaded(state_file):
    def change(arrays, document):
        arrays["simulation/cloth/masses"] = np.array([object()], dtype=object)

    tampered(state_file, change)
    one_line_error(state_file, "ValueError: holds Python objects")


def test_members_no_field_refers_to_are_refused_unread_and_the_total_is_bounded(
    state_file, monkeypatch
):
    import zipfile

    import yore.state

    # an extra member that would inflate to 64 MiB from a few kB: refused without inflating
    with zipfile.ZipFile(state_file, "a", compression=zipfile.ZIP_DEFLATED) as archive:
        with archive.open("bomb.npy", "w", force_zip64=True) as member:
            np.lib.format.write_array_header_1_0(
                member, {"descr": "<f8", "fortran_order": False, "shape": (2**23,)}
            )
            for _ in range(64):
                member.write(bytes(2**20))
    assert state_file.stat().st_size < 2**20
    one_line_error(state_file, "member bomb.npy is not a field the state refers to")
    with pytest.raises(ValueError, match="bomb.npy"):
        yore.state.load_metadata(state_file)
    # the members' declared sizes are summed before any is read
    monkeypatch.setattr(yore.state, "MAX_STATE_FILE_BYTES", 2**25)
    one_line_error(state_file, "declare .* bytes uncompressed in all")


def test_states_that_are_well_formed_but_out_of_range_are_refused(state_file):
    # issue 22, item 13: each passed the schema and then crashed the resume
    def tiny_dt(arrays, document):
        document["simulation"]["dt"] = 5e-324

    tampered(state_file, tiny_dt)
    one_line_error(state_file, "simulation.dt: got float 5e-324; expected a finite number >= 1e-12")


def test_a_duplicated_structural_spring_is_refused(state_file):
    def duplicate(arrays, document):
        for name in (
            "spring_ends",
            "spring_rest",
            "spring_reference",
            "spring_stiffness",
            "spring_damping",
            "spring_kind",
        ):
            key = f"simulation/cloth/{name}"
            arrays[key] = np.concatenate([arrays[key], arrays[key][:1]])

    tampered(state_file, duplicate)
    one_line_error(state_file, "structural springs 0 and 24 join the same vertices")


def test_a_stiffness_past_the_limit_in_a_state_is_refused(state_file):
    def stiff(arrays, document):
        arrays["simulation/cloth/spring_stiffness"] = np.full_like(
            arrays["simulation/cloth/spring_stiffness"], 1e300
        )

    tampered(state_file, stiff)
    one_line_error(state_file, "spring_stiffness|stiffness \\(at most 1e\\+12")


def _rewrite_positions_header(state_file, old, new):
    """The state file with `old` replaced by `new` in its positions member's .npy header (the
    zip's CRC rewritten with it)."""
    import zipfile

    with zipfile.ZipFile(state_file) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    member = "simulation/cloth/positions.npy"
    assert old in members[member]
    members[member] = members[member].replace(old, new, 1)
    with zipfile.ZipFile(state_file, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)


def test_a_header_announcing_more_data_than_stored_allocates_nothing(state_file):
    # Same length, so the header stays well formed.
    _rewrite_positions_header(state_file, b"'shape': (9, 3)", b"'shape':(999,3)")
    one_line_error(state_file, "positions: ValueError: the header announces shape \\(999, 3\\)")


def test_a_header_with_an_unclosed_bracket_is_one_value_error(state_file):
    # numpy parses the header with ast, then retries it with tokenize, which raises its own
    # TokenError (not a ValueError) for a bracket never closed: found by test_fuzz's flips
    _rewrite_positions_header(state_file, b"'shape': (9, 3)", b"'shape': (9, 3 ")
    one_line_error(state_file, "positions: TokenError")


def test_a_fifo_as_state_path_does_not_block(tmp_path):
    fifo = tmp_path / "state.npz"
    os.mkfifo(fifo)
    one_line_error(fifo, "not a regular file")


def test_newtons_projection_memory_is_saved_so_a_resume_decides_the_same():
    # The gathered cloth rejects the exact Hessian in its first step; the next step then waits,
    # projected, as the memory the state carries says.
    def gathered():
        return yore.scenes.hanging_cloth(resolution=7, integrator="implicit", projection="exact")

    straight = gathered()
    straight.step(8)
    sim = gathered()
    sim.step(1)
    state = sim.state()
    assert state["projection_memory"] == {
        "exact_skip": 1,
        "exact_backoff": 2,
        "shift": 0.0,
        "radius": 0.0,
    }
    resumed = yore.Simulation.from_state(state)
    resumed.step(7)
    assert np.array_equal(resumed.cloth.positions, straight.cloth.positions)
    forgetful = yore.Simulation.from_state({**state, "projection_memory": None})
    forgetful.step(7)
    assert not np.array_equal(forgetful.cloth.positions, straight.cloth.positions)
    bad = {**state, "projection_memory": {"exact_skip": -1, "exact_backoff": 1}}
    with pytest.raises(ValueError, match="exact_skip"):
        yore.Simulation.from_state(bad)


# -- issue 41, class 2: whatever save_state writes, load_state reads --------------------------


@pytest.mark.parametrize("integrator", ["local-global", "quasi-newton"])
def test_a_state_with_faces_crushed_flat_saves_and_loads(tmp_path, integrator):
    # gravity 1e15 crushes faces flat in one step; the state was written, then refused as
    # "degenerate" on loading: a state's shape is wherever the simulation took it
    sim = yore.Simulation(
        yore.scenes.hanging_cloth(resolution=7).cloth,
        integrator=integrator,
        dt=0.01,
        gravity=(0.0, -1e15, 0.0),
    )
    with pytest.warns(RuntimeWarning, match="iteration cap"):
        sim.step(2)
    V, F = sim.cloth.positions, sim.cloth.faces
    e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    twice_area = np.linalg.norm(np.cross(e1, e2), axis=1)
    longest = np.max([np.sum(e * e, axis=1) for e in (e1, e2, V[F[:, 2]] - V[F[:, 1]])], axis=0)
    assert (twice_area <= 2e-12 * longest).any()  # some face is degenerate, as a mesh
    path = yore.save_state(tmp_path / "state.npz", sim)
    loaded, _ = yore.load_state(path)
    assert np.array_equal(loaded.cloth.positions, V)
    with pytest.raises(ValueError, match="degenerate"):
        yore.Cloth(V, F)  # a cloth is still built only from a mesh with a shape


def test_save_state_refuses_metadata_that_is_not_a_table(tmp_path):
    sim = yore.Simulation(yore.Cloth(*yore.grid_mesh(3, 3), masses=0.01))
    with pytest.raises(ValueError, match="metadata must be a dict or None, got list"):
        yore.save_state(tmp_path / "state.npz", sim, metadata=[1, 2])
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "field, value, match",
    [
        ("masses", 1e300, "mass of vertex 0"),
        ("spring_rest", 0.0, "rest length"),
        ("spring_kind", 1, "has no structural spring"),
        ("clock_origin", 1e308, "clock_origin"),
    ],
)
def test_save_state_checks_what_it_writes_as_load_state_would(
    tmp_path, monkeypatch, field, value, match
):
    sim = yore.Simulation(yore.Cloth(*yore.grid_mesh(3, 3), masses=0.01))
    state = sim.state()
    cloth = dict(state["cloth"])
    cloth[field] = value if np.isscalar(cloth[field]) else np.full_like(cloth[field], value)
    monkeypatch.setattr(sim, "state", lambda: {**state, "cloth": cloth})
    with pytest.raises(ValueError, match=match) as caught:
        yore.save_state(tmp_path / "state.npz", sim)
    assert "(not written)" in str(caught.value) and "\n" not in str(caught.value)
    assert list(tmp_path.iterdir()) == []


def test_a_state_whose_springs_are_all_bending_springs_is_refused_on_loading(state_file):
    # once accepted by the schema, then an IndexError in the rest area on --resume
    def all_bending(arrays, document):
        key = "simulation/cloth/spring_kind"
        arrays[key] = np.ones_like(arrays[key])

    tampered(state_file, all_bending)
    one_line_error(state_file, r"edge \(0, 1\) of the faces has no structural spring")


def test_a_small_state_that_would_inflate_into_gigabytes_is_refused_unread(tmp_path):
    """Issue 41, class 9: a 1 MB state whose referenced member is a deflated 1 GiB block
    inflated to 2.1 GB before it was refused. The budget comes from the declared shapes (the
    cloth's vertex count) and is checked from the headers before any array is read; the
    member here declares 256 MiB (a few hundred kB compressed), far past a 9-vertex cloth's."""
    import tracemalloc
    import zipfile

    sim = yore.Simulation(yore.Cloth(*yore.grid_mesh(3, 3), masses=0.01))
    path = yore.save_state(tmp_path / "state.npz", sim, metadata={"note": "x"})
    bomb = tmp_path / "bomb.npz"
    big = 256 << 20
    with (
        zipfile.ZipFile(path) as source,
        zipfile.ZipFile(bomb, "w", compression=zipfile.ZIP_DEFLATED) as target,
    ):
        for entry in source.infolist():
            if entry.filename == "simulation/cloth/spring_rest.npy":
                header = np.lib.format.header_data_from_array_1_0(np.zeros(0))
                header["shape"] = (big // 8,)
                with target.open(entry.filename, "w", force_zip64=True) as stream:
                    np.lib.format.write_array_header_1_0(stream, header)
                    block = bytes(1 << 20)
                    for _ in range(big >> 20):
                        stream.write(block)
            else:
                target.writestr(entry, source.read(entry))
    assert bomb.stat().st_size < 2 << 20
    tracemalloc.start()
    try:
        one_line_error(
            bomb,
            r"field simulation.cloth.spring_rest: the simulation arrays "
            r"declare \d+ bytes in all .*refused before reading",
        )
        assert tracemalloc.get_traced_memory()[1] < 32 << 20
    finally:
        tracemalloc.stop()
    with pytest.raises(ValueError, match="more than the limit"):  # the document, likewise
        yore.state._read_npy(_FakeStream(big), big, limit=1 << 20)


def _forge_positions(path, bomb, vertices):
    """``bomb``: the state at ``path`` with its positions member replaced by a deflated block of
    zeros whose header declares ``vertices`` rows (a few hundred kB per 100 MB inflated)."""
    import zipfile

    with (
        zipfile.ZipFile(path) as source,
        zipfile.ZipFile(bomb, "w", compression=zipfile.ZIP_DEFLATED) as target,
    ):
        for entry in source.infolist():
            if entry.filename == "simulation/cloth/positions.npy":
                header = np.lib.format.header_data_from_array_1_0(np.zeros((0, 3)))
                header["shape"] = (vertices, 3)
                with target.open(entry.filename, "w", force_zip64=True) as stream:
                    np.lib.format.write_array_header_1_0(stream, header)
                    block, left = bytes(1 << 20), vertices * 24
                    while left > 0:
                        stream.write(block[: min(left, len(block))])
                        left -= len(block)
            else:
                target.writestr(entry, source.read(entry))


@pytest.mark.parametrize(
    "vertices, message",
    [
        # past any cloth a state may hold: 11 million vertices from a 300 kB member
        (
            11 << 20,
            r"field simulation.cloth.positions: its header declares \d+ vertices, more than "
            r"the 4000000 a state may hold",
        ),
        # within the cap, but the other per-vertex members still say 9
        (
            2_000_000,
            r"field simulation.cloth.velocities: its header declares 9 rows where the "
            r"positions declare 2000000 vertices",
        ),
    ],
)
def test_a_forged_vertex_count_does_not_set_the_budget(tmp_path, vertices, message):
    """Issue 53, N09: the budget trusted the vertex count the bomb's own positions header
    declared (a 1 MB state inflating to 1 GiB peaked at 2.15 GB before it was refused). The
    count is capped, and every per-vertex member must agree with it, before anything is read."""
    import tracemalloc

    sim = yore.Simulation(yore.Cloth(*yore.grid_mesh(3, 3), masses=0.01))
    path = yore.save_state(tmp_path / "state.npz", sim)
    bomb = tmp_path / "bomb.npz"
    _forge_positions(path, bomb, vertices)
    assert bomb.stat().st_size < 2 << 20
    tracemalloc.start()
    try:
        one_line_error(bomb, message + ".*refused before reading")
        assert tracemalloc.get_traced_memory()[1] < 32 << 20
    finally:
        tracemalloc.stop()


def test_arrays_are_inflated_into_one_buffer(tmp_path):
    # _read_npy reads straight into the array: the peak is the array, not the array twice
    import io
    import tracemalloc

    data = np.arange(4 << 20, dtype=np.float64)  # 32 MiB
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, data)
    size = buffer.tell()
    buffer.seek(0)
    tracemalloc.start()
    try:
        read = yore.state._read_npy(buffer, size)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert np.array_equal(read, data)
    assert peak < 1.25 * data.nbytes


class _FakeStream:
    """A .npy stream whose header announces ``size`` bytes of float64 and that holds none:
    reading past the header fails the test."""

    def __init__(self, size):
        import io

        header = np.lib.format.header_data_from_array_1_0(np.zeros(0))
        header["shape"] = (size // 8,)
        self.buffer = io.BytesIO()
        np.lib.format.write_array_header_1_0(self.buffer, header)
        self.buffer.seek(0)
        self.header_end = len(self.buffer.getvalue())

    def read(self, count=-1):
        if self.buffer.tell() >= self.header_end:
            raise AssertionError("read past the header")
        return self.buffer.read(count)


def test_a_state_too_large_to_load_is_not_written(tmp_path):
    # Issue 53, N02: a 70 MB metadata string was written, and load_state refused the file
    sim = yore.Simulation(yore.Cloth(*yore.grid_mesh(3, 3), masses=0.01))
    target = tmp_path / "state.npz"
    with pytest.raises(ValueError, match=r"not written\): the state's document is \d+ characters"):
        yore.save_state(target, sim, metadata={"note": "x" * (65 << 20)})
    with pytest.raises(ValueError, match=r"not written\): the metadata's arrays hold \d+ bytes"):
        yore.save_state(target, sim, metadata={"big": np.zeros((257 << 20) // 8)})
    assert not target.exists() and not list(tmp_path.iterdir())
    near = yore.save_state(target, sim, metadata={"note": "x" * (1 << 20)})
    assert yore.state.load_metadata(near)["note"] == "x" * (1 << 20)


def test_the_cloth_state_fields_are_the_cores_one_list():
    # issue 54, item 3: the binding's list (Cloth.state_fields) is what its writer writes, what
    # its reader requires and what the state file's schema checks; the optional keys are those
    # a state saved before quadratic bending, the membrane, the fitted operator or the smoothed
    # strain lacks, and such a state still loads.
    fields = yore.Cloth.state_fields
    required, optional = set(fields["required"]), set(fields["optional"])
    assert required and optional and not required & optional
    from yore.state_schema import CLOTH

    assert set(CLOTH) == required  # the state file's table declares each required field
    assert {"bending", "young_modulus", "membrane_strain"} <= optional
    cloth = yore.Cloth(*yore.grid_mesh(4, 4), masses=0.01)
    state = cloth.state()
    assert set(state) == required | optional  # the writer writes every key it knows
    older = yore.Cloth.from_state({k: v for k, v in state.items() if k in required})
    assert older.bending == "springs" and older.stretch == "springs"
    np.testing.assert_array_equal(older.positions, cloth.positions)
    with pytest.raises(ValueError, match="masses"):  # a required key is required
        yore.Cloth.from_state({k: v for k, v in state.items() if k != "masses"})


def test_every_field_of_the_schema_tables_is_checked_by_its_rule(state_file):
    # issue 54, item 3: the state's fields are declared once, in the tables of
    # yore.state_schema; each declared field refuses a value of the wrong kind with its name
    from yore import state_schema as schema

    tables = {
        ("simulation",): schema.SIMULATION,
        ("simulation", "cloth"): schema.CLOTH,
        ("simulation", "projection_memory"): schema.PROJECTION_MEMORY,
    }
    checked = 0
    for where, table in tables.items():
        for name, spec in table.items():
            if spec is None:  # a table of its own, or checked against the integrator
                continue
            path = state_file.with_name(f"{'.'.join(where)}.{name}.npz")
            path.write_bytes(state_file.read_bytes())

            def change(arrays, document, where=where, name=name):
                node = document
                for part in where:
                    node = node[part]
                node[name] = "x"
                arrays.pop("/".join((*where, name)), None)

            tampered(path, change)
            dotted = re.escape(".".join((*where, name)))
            one_line_error(path, rf"field {dotted}: got str 'x'; expected ")
            checked += 1
    assert checked >= 20
