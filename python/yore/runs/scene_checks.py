"""A scene file's checks: every table of `yore.runs.schema.SCHEMA` key by key, then the keys
that go together (one way to give the mass, the stretching and bending models' own keys, one
form per stroke, frames and pictures that fit, settle without driven vertices) and the
integrator's options, into the typed tree `yore.runs.scene_tables.SceneData`
(`checked_data`). Each problem is one `SceneError` naming its key, through ``Scene.error``."""

from __future__ import annotations

from ..checks import MAX_IMAGE_PIXELS
from ..meshes import MAX_MESH_VERTICES
from ..options import (
    FRAMES_PER_SECOND,
    INTEGRATOR_OPTIONS,
    MASS,
    POISSON_RATIO,
    STIFFNESS,
    OptionError,
    check_option,
)
from .scene_tables import TABLES, BoxTable, SceneData, SmoothTable
from .schema import (
    BOX,
    GENERATOR_KEYS,
    REQUIRED,
    SCHEMA,
    SCHEMA_GENERATOR_EXPECTED,
    SELECTION,
    SMOOTH,
    STROKE_FORMS,
    Invalid,
    describe_value,
    did_you_mean,
)

__all__ = ["checked_data"]


def checked_data(scene, raw):
    """The scene's tables checked key by key and together, as a `SceneData` tree; the first
    problem raises `SceneError` through ``scene.error`` (its key and line)."""
    data = _check_tables(scene, raw)
    _check_material(scene, data.material, raw)
    _check_vertices_and_strokes(scene, data)
    _check_output(scene, data)
    data.integrator = _check_integrator(
        scene, raw.get("integrator", {}), data.simulation.integrator
    )
    return data


def _check_tables(scene, raw):
    """Every table of the schema, checked key by key (the [integrator] table aside)."""
    unknown = [key for key in raw if key not in SCHEMA]
    if unknown:
        key = unknown[0]
        raise scene.error(
            key,
            f"unknown table or key{did_you_mean(key, SCHEMA)}",
            "one of the tables " + ", ".join(f"[{k}]" for k in SCHEMA),
        )
    data = SceneData()
    for name, table in SCHEMA.items():
        if name == "integrator":
            continue
        value, keys = raw.get(name), table.keys
        if table.kind == "array":
            setattr(data, name, _check_array_of_tables(scene, name, value, keys))
            continue
        setattr(data, name, _check_single_table(scene, name, value, keys))
        if name == "mesh":
            _check_mesh_size(scene, data.mesh)
        if name == "camera":
            _check_camera_size(scene, data.camera)
    return data


def _check_array_of_tables(scene, name, value, keys):
    """[[name]] tables (none: an empty list), each checked key by key."""
    if value is None:
        value = []
    if not isinstance(value, list) or any(not isinstance(v, dict) for v in value):
        raise scene.error(
            name, f"got {describe_value(value)}", f"[[{name}]] tables (an array of tables)"
        )
    return [
        _check_table(scene, f"{name}[{k}]", entry, keys, TABLES[name])
        for k, entry in enumerate(value)
    ]


def _check_single_table(scene, name, value, keys):
    """A [name] table checked key by key ([mesh] and [simulation] are required; the mesh's
    keys include its generator's)."""
    if value is None:
        if name in ("mesh", "simulation"):
            raise scene.error(name, "missing", f"a [{name}] table")
        value = {}
    if not isinstance(value, dict):
        raise scene.error(name, f"got {describe_value(value)}", f"a [{name}] table")
    if name == "mesh":
        generator = value.get("generator")
        if generator is None:
            raise scene.error("mesh.generator", "missing", SCHEMA_GENERATOR_EXPECTED)
        keys = dict(keys)
        if isinstance(generator, str) and generator in GENERATOR_KEYS:
            keys.update(GENERATOR_KEYS[generator])
    return _check_table(scene, name, value, keys, TABLES[name])


def _check_material(scene, material, raw):
    """One way to give the mass; bending and stretching models with their own keys."""
    given = material.given("mass", "mass_per_vertex", "density")
    if len(given) > 1:
        raise scene.error(
            f"material.{given[1]}",
            f"given together with material.{given[0]}",
            "one of mass (total), mass_per_vertex or density",
        )
    if not given:
        material.mass = MASS
    model = material.bending
    if model in ("quadratic", "hinge"):
        if material.bending_modulus is None:
            raise scene.error(
                "material.bending_modulus",
                f'missing with bending = "{model}"',
                "a number >= 0 (N·m)",
            )
        if material.bend_stiffness not in (None, 0.0):
            raise scene.error(
                "material.bend_stiffness",
                f'given with bending = "{model}", which creates no bending springs',
                "no bend_stiffness (or 0)",
            )
        material.bend_stiffness = None
    else:
        if material.bending_modulus is not None:
            raise scene.error(
                "material.bending_modulus",
                'given with bending = "springs"',
                'bending = "quadratic", or bend_stiffness for the springs',
            )
        if material.bend_stiffness is None:
            material.bend_stiffness = STIFFNESS
    _check_stretch(scene, material, raw.get("material", {}))


def _check_vertices_and_strokes(scene, data):
    """Fixed and driven selections; each stroke one form, before the run's end."""
    for k, entry in enumerate(data.fixed):
        _check_selection(scene, f"fixed[{k}]", entry)
    for k, entry in enumerate(data.driven):
        _check_selection(scene, f"driven[{k}]", entry)
    duration = data.simulation.duration
    for k, stroke in enumerate(data.strokes):
        forms = stroke.given(*STROKE_FORMS)
        if len(forms) != 1:
            raise scene.error(
                f"strokes[{k}]",
                f"gives {len(forms)} of points, material, screen",
                "exactly one of them",
            )
        if stroke.max_distance is not None and forms[0] != "points":
            raise scene.error(
                f"strokes[{k}].max_distance",
                f"given for a {forms[0]} stroke",
                "max_distance only with points",
            )
        if stroke.time >= duration:
            raise scene.error(
                f"strokes[{k}].time",
                f"{stroke.time:g} s is not before the end of the run ({duration:g} s)",
                "a time before simulation.duration",
            )


def _check_output(scene, data):
    """Frames, pictures and animations that fit together; settle without driven vertices."""
    output = data.output
    if output.fps is not None and output.every_steps is not None:
        raise scene.error(
            "output.every_steps", "given together with output.fps", "one of fps or every_steps"
        )
    if output.every_steps is None and output.fps is None:
        output.fps = FRAMES_PER_SECOND
    if output.animation != "none" and output.format == "none":
        raise scene.error(
            "output.animation",
            "an animation needs frames, but output.format is 'none'",
            "format = 'vtu', 'vtk', 'ply' or 'obj'",
        )
    if output.pictures and output.format != "none":
        _check_pictures_size(scene, data.camera)
    if data.simulation.settle > 0.0 and data.driven:
        raise scene.error(
            "simulation.settle",
            "given for a scene with [[driven]] vertices, "
            "which keep moving and have no rest to settle to",
            "settle = 0",
        )


def _check_mesh_size(scene, mesh):
    """The generated mesh's vertex count, estimated before anything is built."""
    sizes = {"grid": ("nx", "ny"), "cylinder": ("rings", "segments")}.get(mesh.generator)
    if sizes is None:
        return
    first, second = (getattr(mesh, key) for key in sizes)
    count = first * second
    if count > MAX_MESH_VERTICES:
        key = sizes[0] if first >= second else sizes[1]
        raise scene.error(
            f"mesh.{key}",
            f"{sizes[0]} × {sizes[1]} = {first} × {second} = {count} vertices",
            f"at most {MAX_MESH_VERTICES} vertices",
        )


def _check_camera_size(scene, camera):
    pixels = camera.width * camera.height
    if pixels > MAX_IMAGE_PIXELS:
        key = "width" if camera.width >= camera.height else "height"
        raise scene.error(
            f"camera.{key}",
            f"{camera.width} × {camera.height} = {pixels} pixels",
            f"at most {MAX_IMAGE_PIXELS} pixels in all",
        )


def _check_pictures_size(scene, camera):
    """The before/after picture (two camera images side by side, titled) within the image
    limit, before the run (a 4096×2048 camera failed only after it)."""
    from ..viz.images import side_by_side_shape

    height, width = side_by_side_shape([camera.width] * 2, camera.height, titled=True)
    if width * height > 2 * MAX_IMAGE_PIXELS:
        key = "width" if camera.width >= camera.height else "height"
        raise scene.error(
            f"camera.{key}",
            f"{camera.width} × {camera.height} makes the "
            f"before/after picture {width} × {height} = {width * height} pixels",
            f"at most {2 * MAX_IMAGE_PIXELS} pixels (two images of at most "
            f"{MAX_IMAGE_PIXELS} side by side), or output.pictures = false",
        )


def _check_table(scene, where, table, keys, kind):
    """``table`` (the file's dict) checked against ``keys`` (the schema's), as a ``kind``."""
    checked = kind()
    for key, value in table.items():
        if key not in keys:
            raise scene.error(
                f"{where}.{key}",
                f"unknown key{did_you_mean(key, keys)}",
                "one of " + ", ".join(keys),
            )
        checker = keys[key].rule
        if checker in ("box", "smooth"):
            subtable = {"box": (BOX, BoxTable), "smooth": (SMOOTH, SmoothTable)}[checker]
            value = _check_table(
                scene, f"{where}.{key}", _as_table(scene, where, key, value), *subtable
            )
            setattr(checked, key, value)
            continue
        try:
            setattr(checked, key, checker(value))
        except Invalid as invalid:
            raise scene.error(f"{where}.{key}", invalid.problem, invalid.expected) from None
    for key, spec in keys.items():
        checker, default = spec.rule, spec.default
        if getattr(checked, key) is not None:
            continue
        if default is REQUIRED:
            expected = getattr(checker, "expected", "a value")
            raise scene.error(f"{where}.{key}", "missing", expected)
        if default is not None and checker not in ("box", "smooth"):
            setattr(checked, key, checker(default) if isinstance(default, list) else default)
    return checked


def _as_table(scene, where, key, value):
    if not isinstance(value, dict):
        raise scene.error(f"{where}.{key}", f"got {describe_value(value)}", "an inline table {...}")
    return value


def _check_selection(scene, where, entry):
    given = entry.given(*SELECTION)
    if len(given) != 1:
        raise scene.error(
            where, f"selects vertices by {len(given)} of indices, box, set", "exactly one of them"
        )


def _check_integrator(scene, options, integrator):
    if not isinstance(options, dict):
        raise scene.error("integrator", f"got {describe_value(options)}", "an [integrator] table")
    table = INTEGRATOR_OPTIONS.get(integrator, {})
    checked = {}
    for key, value in options.items():
        if key not in table:
            raise scene.error(
                f"integrator.{key}",
                f"unknown option of the {integrator!r} integrator{did_you_mean(key, table)}",
                "one of " + (", ".join(sorted(table)) or "no options"),
            )
        try:
            checked[key] = check_option(integrator, key, value)
        except OptionError as invalid:
            raise scene.error(f"integrator.{key}", f"got {invalid.got}", invalid.expected) from None
    return checked


def _check_stretch(scene, material, given):
    """stretch = "membrane" needs young_modulus and takes no stretch_stiffness; springs take
    neither young_modulus nor poisson_ratio. `material` has the defaults applied; `given` is
    the file's own table, which tells a stretch_stiffness the file gave from the default."""
    if material.stretch == "membrane":
        if material.young_modulus is None:
            raise scene.error(
                "material.young_modulus", 'missing with stretch = "membrane"', "a number > 0 (N/m)"
            )
        if "stretch_stiffness" in given:
            raise scene.error(
                "material.stretch_stiffness",
                'given with stretch = "membrane", whose structural springs carry no stiffness',
                "no stretch_stiffness",
            )
        material.stretch_stiffness = None
        if material.poisson_ratio is None:
            material.poisson_ratio = POISSON_RATIO
    else:
        extra = material.given("young_modulus", "poisson_ratio", "membrane_strain")
        if extra:
            raise scene.error(
                f"material.{extra[0]}",
                'given with stretch = "springs"',
                'stretch = "membrane", or stretch_stiffness for the springs',
            )
