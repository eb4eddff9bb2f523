"""The Python module against the btfgmm command: the same models, values, images and metrics.

Run by CTest (run_pytest.py), which puts the built module on sys.path and names the built
command in BTFGMM_CLI. The data is tiny: an 8 x 8 generated BTF of 11 lights x 6 views.
"""
import json
import os
import signal
import struct
import subprocess
import sys

import numpy as np
import pytest

import btfgmm

CLI = os.environ.get("BTFGMM_CLI", "btfgmm")
SETS = ["--lights", "rings:0/1,30/4,60/6", "--views", "rings:0/1,45/5"]


def cli(*args):
    """The command's stdout; a failure shows its stderr."""
    r = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, f"btfgmm {' '.join(map(str, args))}: {r.stderr}"
    return r.stdout


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("btfgmm")
    btf = str(d / "btf")
    cli("generate", "--material", "knit", "--size", 8, "--seed", 3, *SETS, "-q", "-o", btf)
    gm = str(d / "cli-gm.btfgmm")
    cli("fit", btf, "--tile", "0,0,6,6", "-M", 5, "--iterations", 3, "--seed", 2, "--threads", 2,
        "-q", "-o", gm)
    pca = str(d / "cli-pca.btfgmm")
    cli("fit", btf, "--tile", "1,2,6,5", "--method", "pca-btf", "--components", 3,
        "--threads", 2, "-q", "-o", pca)
    neural = str(d / "cli-neural.btfgmm")
    cli("fit", btf, "--tile", "0,0,6,6", "--method", "neural", "--components", 3, "--width", 8,
        "--iterations", 2, "--seed", 4, "--threads", 1, "-q", "-o", neural)
    return {"dir": d, "btf": btf, "gm": gm, "pca": pca, "neural": neural}


def random_queries(rng, n):
    q = np.empty((n, 6))
    q[:, 0:2] = rng.uniform(-4.0, 12.0, (n, 2))  # the tile repeats
    q[:, 2] = rng.uniform(0.0, 90.0, n)
    q[:, 3] = rng.uniform(-180.0, 540.0, n)  # wrapped into [0, 360) by both
    q[:, 4] = rng.uniform(0.0, 90.0, n)
    q[:, 5] = rng.uniform(0.0, 360.0, n)
    return q


@pytest.mark.parametrize("which", ["gm", "pca", "neural"])
def test_eval_equals_the_command(work, which):
    model = btfgmm.load(work[which])
    q = random_queries(np.random.default_rng(11), 4)
    got = model.eval(q)
    assert got.shape == (4, 3) and got.dtype == np.float32
    for row, rgb in zip(q, got):
        j = json.loads(cli("eval", work[which], "--json", "--x", repr(row[0]), "--y",
                           repr(row[1]), "--light", f"{row[2]!r},{row[3]!r}", "--view",
                           f"{row[4]!r},{row[5]!r}"))
        # The command's floats, printed in full by its JSON, are the module's.
        np.testing.assert_allclose(rgb, np.float32(j["rgb"]), rtol=1e-6, atol=0)
    assert np.all(got > 0)  # a knit under these lights: no black pixel
    one = model.eval(q[0])  # one query, one RGB
    assert one.shape == (3,) and np.array_equal(one, got[0])


def test_a_model_loaded_onto_the_gpu_gives_the_cpus_values(work):
    """device="gpu" (lavapipe in CI) computes the mixture's and the neural BTF's predictions
    on the device."""
    try:
        gpu = btfgmm.load(work["gm"], device="gpu")
    except btfgmm.ArgumentError as e:
        if "no Vulkan device" in str(e) and os.environ.get("CI") != "true":
            pytest.skip(str(e))
        raise
    cpu = btfgmm.load(work["gm"], device="cpu")
    q = random_queries(np.random.default_rng(5), 50)
    np.testing.assert_allclose(gpu.eval(q), cpu.eval(q), rtol=0, atol=1e-3)
    a = gpu.decode((30, 45), (20, 100), size=(10, 7))
    b = cpu.decode((30, 45), (20, 100), size=(10, 7), tolerance=0)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-3)
    nn_gpu = btfgmm.load(work["neural"], device="gpu")
    nn_cpu = btfgmm.load(work["neural"], device="cpu")
    np.testing.assert_allclose(nn_gpu.eval(q), nn_cpu.eval(q), rtol=0, atol=1e-3)
    np.testing.assert_allclose(nn_gpu.decode((30, 45), (20, 100), size=(10, 7)),
                               nn_cpu.decode((30, 45), (20, 100), size=(10, 7)), rtol=0, atol=1e-3)
    # The neural fit's passes on the device too: the CPU's model to float rounding.
    fitted = btfgmm.fit(work["btf"], tile=(0, 0, 6, 6), method="neural", components=3, width=8,
                        iterations=2, seed=4, device="gpu")
    np.testing.assert_allclose(fitted.eval(q), nn_cpu.eval(q), rtol=0, atol=0.05)
    with pytest.raises(btfgmm.ArgumentError, match="cpu or auto"):
        btfgmm.load(work["pca"], device="gpu")
    with pytest.raises(btfgmm.ArgumentError, match="'auto', 'cpu' or 'gpu'"):
        btfgmm.load(work["gm"], device="tpu")


def quantise(v):
    """As the command writes 8-bit images: rounded half away from zero, clamped to 0..255."""
    v = np.asarray(v, dtype=np.float64)
    return np.where(v >= 0.0, np.floor(np.minimum(v, 255.0) + 0.5), 0.0)


@pytest.mark.parametrize("which", ["gm", "pca"])
def test_decode_equals_the_command_png(work, which):
    out = work["dir"] / f"decoded-{which}"
    cli("decode", work[which], "--light", "30,45", "--view", "20,100", "--size", "10x7", "-o",
        out)
    png = btfgmm.read_btf(out)
    assert png.values.shape == (1, 1, 7, 10, 3)
    np.testing.assert_array_equal(png.lights, [[30.0, 45.0]])
    image = btfgmm.load(work[which]).decode((30, 45), (20, 100), size=(10, 7))
    assert image.shape == (7, 10, 3) and image.dtype == np.float32
    assert np.array_equal(quantise(image), png.values[0, 0])
    assert np.ptp(png.values) > 10  # a picture, not a flat colour


def provenance_times(data):
    """The byte ranges of a model file where its provenance has room for times (docs/FORMAT.md,
    "Provenance"): the fit's time, each EM iteration's time, then the CRC. Parsed field by field; the section must be consumed exactly."""
    u32 = lambda at: struct.unpack_from("<I", data, at)[0]
    at = 24
    at += 4 + u32(at)  # the method tag
    size, at = u32(at), at + 4
    end = at + size
    at += 4 + u32(at)  # source
    at += 4 + 4 + 8  # image size, content hash
    times = [(at, at + 8)]  # the fit's seconds
    at += 8 + 4  # ... and runs
    count, at = u32(at), at + 4
    for _ in range(count):  # the settings, (name, value) pairs
        at += 4 + u32(at)
        at += 4 + u32(at)
    iterations, at = u32(at), at + 4
    for _ in range(iterations):  # L, time, components
        times.append((at + 8, at + 16))
        at += 20
    assert at == end, "the provenance section was not parsed exactly"
    times.append((len(data) - 4, len(data)))  # the CRC
    return times


def test_fit_equals_the_command_byte_for_byte(work, tmp_path):
    model = btfgmm.fit(work["btf"], tile=(0, 0, 6, 6), components=5, iterations=3, seed=2,
                       threads=2)
    assert model.method == "gm" and model.size == "M = 5"
    out = tmp_path / "py-gm.btfgmm"
    assert model.save(out) == os.path.getsize(out)
    a, b = open(out, "rb").read(), open(work["gm"], "rb").read()
    # The same data, options and seed: the same file, byte for byte, with 2 threads here and
    # the command's default there. No time is recorded in it.
    assert a == b
    ranges = provenance_times(a)
    assert len(ranges) == 3 + 2  # the fit's time, 3 iterations, the CRC
    assert all(a[x:y] == bytes(y - x) for x, y in ranges[:-1])
    p = model.provenance
    assert p["source"] == work["btf"] and "threads" not in p["settings"]
    assert p["settings"]["components"] == "5" and len(p["iterations"]) == 3


def test_fit_of_another_method_equals_the_command(work, tmp_path):
    data = btfgmm.read_btf(work["btf"], tile="1,2,6,5")  # a Btf fits on its own tile
    model = btfgmm.fit(data, method="pca-btf", components=3, threads=2)
    out = tmp_path / "py-pca.btfgmm"
    model.save(out)
    assert open(out, "rb").read() == open(work["pca"], "rb").read()
    assert model.method == "pca-btf" and model.parameters == btfgmm.load(work["pca"]).parameters


def test_a_neural_fit_equals_the_command_on_other_threads(work, tmp_path):
    # The command fitted it on 1 thread; the module on 2 writes the same bytes.
    data = btfgmm.read_btf(work["btf"], tile="0,0,6,6")
    model = btfgmm.fit(data, method="neural", components=3, width=8, iterations=2, seed=4,
                       threads=2)
    out = tmp_path / "py-neural.btfgmm"
    model.save(out)
    assert open(out, "rb").read() == open(work["neural"], "rb").read()
    assert model.method == "neural" and model.size == "L = 3, 2 x 8"


def test_ctrl_c_in_a_neural_fit_returns_the_best_model_met(work):
    def stop_in_epoch_two(fraction, stage):
        if stage.startswith("epoch 2 of"):
            raise KeyboardInterrupt

    with pytest.warns(RuntimeWarning, match="stopped by Ctrl-C; the model of the lowest"):
        kept = btfgmm.fit(work["btf"], tile=(0, 0, 6, 6), method="neural", components=3,
                          width=8, iterations=50, seed=4, progress=stop_in_epoch_two)
    assert kept.method == "neural"
    assert kept.provenance["settings"]["stopped by the user"].startswith("in epoch 2 of 50")


def test_fit_takes_the_objective_and_the_pyramid_levels(work, tmp_path):
    paper = btfgmm.fit(work["btf"], tile=(0, 0, 6, 6), components=5, iterations=3, seed=2,
                       objective="likelihood")
    assert paper.provenance["settings"]["objective"] == "likelihood"
    with pytest.raises(btfgmm.Error, match="objective"):
        btfgmm.fit(work["btf"], tile=(0, 0, 6, 6), components=5, objective="likelyhood")
    # A refinement bounded in epochs, not time: recorded, and ended by that bound.
    bounded = btfgmm.fit(work["btf"], tile=(0, 0, 6, 6), components=5, iterations=3, seed=2,
                         refine_epochs=2)
    assert bounded.provenance["settings"]["refine epochs"] == "2"
    assert "in 2 epochs (epoch bound)" in bounded.provenance["settings"]["refinement"]
    with pytest.raises(ValueError, match="refine_epochs applies to the objective prediction"):
        btfgmm.fit(work["btf"], tile=(0, 0, 6, 6), components=5, objective="likelihood",
                   refine_epochs=2)
    car = btfgmm.fit(work["btf"], method="3d-car", clusters=2, levels=1)
    assert car.provenance["settings"]["levels"] == "1"
    with pytest.raises(btfgmm.Error, match="levels 3"):
        btfgmm.fit(work["btf"], method="3d-car", clusters=2, levels=3)


def test_compare_equals_the_command_json(work):
    for which in ("gm", "pca"):
        got = btfgmm.compare(work["btf"], btfgmm.load(work[which]))
        want = json.loads(cli("compare", work["btf"], work[which], "--json", "-q"))
        for d in (got, want):
            del d["decode_seconds"]  # the only time measured here
        assert got == want
        assert 10 < got["psnr_db"] < 60 and got["data_match"] == "same"


def test_model_properties(work):
    model = btfgmm.load(work["gm"])
    info = json.loads(cli("info", work["gm"], "--json"))
    assert model.method == "gm" and model.size == "M = 5"
    assert model.parameters == info["parameters"]
    assert model.file_bytes == os.path.getsize(work["gm"])
    assert model.paper_ratio == pytest.approx(info["compression_ratio_paper"], rel=1e-12)
    assert model.file_ratio == pytest.approx(info["compression_ratio_file"], rel=1e-12)
    f = model.frame
    assert (f["width"], f["height"], f["origin"]) == (6, 6, (0, 0, 6, 6))
    assert f["lights"].shape == (11, 2) and f["views"].shape == (6, 2)
    data = json.loads(cli("info", work["btf"], "--json"))
    np.testing.assert_array_equal(f["lights"], data["light_directions"])
    np.testing.assert_array_equal(f["views"], data["view_directions"])
    assert model.details["components_requested"] == 5


def test_read_btf(work):
    whole = btfgmm.read_btf(work["btf"])
    assert whole.values.shape == (11, 6, 8, 8, 3) and whole.values.dtype == np.float32
    assert whole.image_size == (8, 8) and whole.format == "8-bit"
    assert np.array_equal(whole.values, np.round(whole.values))  # 8-bit levels, exactly
    tile = btfgmm.read_btf(work["btf"], tile=(2, 1, 4, 3))
    assert tile.origin == (2, 1, 4, 3)
    assert np.array_equal(tile.values, whole.values[:, :, 1:4, 2:6])
    assert np.array_equal(np.asarray(tile), tile.values)
    assert np.asarray(tile, dtype=np.float64).dtype == np.float64
    assert tile.lights[0].tolist() == [0.0, 0.0] and tile.views.shape == (6, 2)


def test_a_seamless_tile_is_the_commands_and_fits_and_compares_as_made(work, tmp_path):
    made = btfgmm.seamless_tile(work["btf"], (5, 5))
    assert made.values.shape == (11, 6, 5, 5, 3)
    assert made.made_from == "seamless 5x5 tile cut from " + made.made_from.split("from ")[1]
    out = tmp_path / "tile"
    cli("tile", work["btf"], "--size", "5x5", "-o", out, "-q")
    assert np.array_equal(made.values, btfgmm.read_btf(out).values)  # the command's images
    assert json.loads((out / "seamless-tile.json").read_text())["width"] == 5
    model = btfgmm.fit(made, components=3, iterations=2, quiet=True)
    model.save(tmp_path / "made.btfgmm")
    assert model.frame["width"] == 5
    got = btfgmm.compare(made, btfgmm.load(tmp_path / "made.btfgmm"))  # the file, as stored
    want = json.loads(cli("compare", work["btf"], tmp_path / "made.btfgmm", "--json", "-q"))
    for d in (got, want):
        del d["decode_seconds"]
    assert got == want and got["data_match"] == "same"
    with pytest.raises(btfgmm.ArgumentError, match="at most 6x6"):
        btfgmm.seamless_tile(work["btf"], (7, 7))


def test_errors_are_exceptions_with_the_library_messages(work, tmp_path):
    with pytest.raises(OSError) as e:
        btfgmm.load(tmp_path / "missing.btfgmm")
    assert isinstance(e.value, btfgmm.Error) and "missing.btfgmm" in str(e.value)
    text = tmp_path / "notes.btfgmm"
    text.write_text("not a model\n")
    with pytest.raises(btfgmm.FormatError, match="notes.btfgmm"):
        btfgmm.load(text)
    with pytest.raises(btfgmm.Error):
        btfgmm.read_btf(tmp_path / "nothing-here")
    model = btfgmm.load(work["gm"])
    with pytest.raises(ValueError, match=r"N x 6 array.*shape \(3, 5\)"):
        model.eval(np.zeros((3, 5)))
    with pytest.raises(ValueError, match=r"query 1: light .*off the upper hemisphere"):
        model.eval([[0, 0, 30, 0, 0, 0], [0, 0, 95, 0, 0, 0]])
    with pytest.raises(btfgmm.ArgumentError, match="size"):
        model.decode((30, 45), (0, 0), size=0)
    with pytest.raises(btfgmm.ArgumentError, match="did you mean 'gm'"):
        btfgmm.fit(work["btf"], method="gmm")
    with pytest.raises(ValueError, match="epsilon cannot apply to method pca-btf"):
        btfgmm.fit(work["btf"], method="pca-btf", epsilon=0.01)
    with pytest.raises(ValueError, match="refine_seconds cannot apply to method pca-btf"):
        btfgmm.fit(work["btf"], method="pca-btf", refine_seconds=5)
    with pytest.raises(ValueError, match="exists; give a new name or pass overwrite=True"):
        model.save(work["pca"])
    # A misspelt option is no silent default.
    with pytest.raises(btfgmm.ArgumentError, match="no option 'componnets' .did you mean 'components'"):
        btfgmm.fit(work["btf"], componnets=5)


# Every value the command refuses by range, Python refuses with the same rule, naming its
# keyword as passed; and sweep and budget refuse the same values (the library's one check).
@pytest.mark.parametrize("method,field,value", [
    ("gm", "epsilon", 5), ("gm", "iterations", 0), ("gm", "components", 0),
    ("gm", "refine_epochs", 0), ("gm", "refine_steps", 0), ("gm", "refine_seconds", 0.5),
    ("gm", "threads", 2000), ("gm", "seed", -1), ("gm", "objective", "best"),
    ("gm", "device", "tpu"), ("gm", "precision", "f8"), ("lpca", "clusters", 0),
    ("plm-rf", "degree", 65), ("3d-car", "levels", 17), ("gm", "iterations", 2.5)])
def test_python_refuses_what_the_command_refuses(work, tmp_path, method, field, value):
    with pytest.raises(btfgmm.ArgumentError) as python:
        btfgmm.fit(work["btf"], method=method, **{field: value})
    flag = "--" + field.replace("_", "-")
    r = subprocess.run([CLI, "fit", work["btf"], "--method", method, flag, str(value), "-o",
                        str(tmp_path / "m.btfgmm")], capture_output=True, text=True)
    assert r.returncode != 0 and not (tmp_path / "m.btfgmm").exists()
    command = r.stderr.strip().removeprefix("btfgmm: error: ").replace("-M/--components", flag)
    assert str(python.value).startswith(f"{field}={value}: "), str(python.value)
    assert "; give " in str(python.value)
    assert command == str(python.value).replace(f"{field}={value}", f"{flag} {value}", 1)
    if field in ("iterations", "refine_epochs", "refine_seconds", "threads", "seed"):
        for route in (["sweep", work["btf"], "--tile", "0,0,4,4", "-o", str(tmp_path / "s")],
                      ["fit", work["btf"], "--budget", "9000", "-o", str(tmp_path / "b.btfgmm")]):
            r = subprocess.run([CLI, *route, flag, str(value)], capture_output=True, text=True)
            assert r.stderr.strip().removeprefix("btfgmm: error: ") == command, route[0]


def test_progress_and_stopping_a_fit(work):
    calls = []

    def progress(fraction, stage):
        calls.append((fraction, stage))
        if len(calls) == 2:
            raise KeyboardInterrupt  # as Ctrl-C would: the fit stops after this iteration

    with pytest.raises(KeyboardInterrupt):
        btfgmm.fit(work["btf"], tile=(0, 0, 6, 6), components=5, iterations=30, seed=2,
                   progress=progress)
    assert calls == [(1 / 30, "EM"), (2 / 30, "EM")]

    # The refinement for the prediction reports its steps after EM's iterations, and Ctrl-C
    # there is raised once the fit has stopped (that the steps end there is the C++ tests'
    # RefineGradient.StopEndsTheStepsWithTheBestMet).
    stages = []
    btfgmm.fit(work["btf"], tile=(0, 0, 6, 6), components=5, iterations=3, seed=2,
               progress=lambda fraction, stage: stages.append((fraction, stage)))
    assert [s for _, s in stages[:3]] == ["EM"] * 3
    assert {s for _, s in stages[3:]} == {"colour refit", "refinement"}
    # A colour refit's share grows as its lights are summed, up to the whole, twice.
    refits = [f for f, s in stages[3:] if s == "colour refit"]
    assert refits.count(1) == 2 and all(0 < f <= 1 for f in refits)
    refinement = [f for f, s in stages[3:] if s == "refinement"]
    assert refinement[0] == 0 and refinement[-1] == 1
    calls = []

    def stop_in_refinement(fraction, stage):
        calls.append(stage)
        if stage == "refinement" and fraction > 0.2:
            raise KeyboardInterrupt

    # Stopped in the refinement, the model of the lowest held-out error met is returned, as
    # the command writes it, with a warning; its provenance says the steps were stopped.
    with pytest.warns(RuntimeWarning, match="stopped by Ctrl-C; the model of the lowest"):
        kept = btfgmm.fit(work["btf"], tile=(0, 0, 6, 6), components=5, iterations=3, seed=2,
                          progress=stop_in_refinement)
    assert calls[:3] == ["EM"] * 3 and 3 < len(calls) < len(stages)
    assert "(stopped)" in kept.provenance["settings"]["refinement"]


def test_fit_tells_its_progress_on_stderr_unless_quiet(work, capfd):
    btfgmm.fit(work["btf"], tile=(0, 0, 6, 6), components=5, iterations=3, seed=2)
    err = capfd.readouterr().err
    assert "fit: EM iteration 1/3, L = " in err and "fit: EM iteration 3/3" in err
    assert "fit: refinement 100 %" in err
    btfgmm.fit(work["btf"], tile=(0, 0, 6, 6), components=5, iterations=3, seed=2, quiet=True)
    assert capfd.readouterr().err == ""


def test_ctrl_c_stops_a_fit_in_em(work):
    # A real SIGINT, as Ctrl-C sends it, once EM has begun: KeyboardInterrupt in Python.
    code = ("import btfgmm\n"
            f"btfgmm.fit({work['btf']!r}, tile=(0, 0, 8, 8), components=40, iterations=1000, epsilon=0, seed=2)\n")
    folder = os.path.dirname(os.path.dirname(btfgmm.__file__))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [folder, os.path.dirname(btfgmm.__file__), os.environ.get("PYTHONPATH", "")]))
    p = subprocess.Popen([sys.executable, "-c", code], stderr=subprocess.PIPE, text=True, env=env)
    seen = ""
    while "fit: EM iteration 2/" not in seen:
        line = p.stderr.readline()
        assert line, seen
        seen += line
    p.send_signal(signal.SIGINT)
    rest = p.communicate(timeout=60)[1]
    assert p.returncode != 0 and "KeyboardInterrupt" in rest, rest


def test_a_python_without_numpy_is_told_what_to_install():
    # numpy made unimportable (as on a Python that lacks it); the module's folder on the path.
    code = ("import sys; sys.modules['numpy'] = None\n"
            "try:\n    import btfgmm\nexcept ImportError as e:\n    print(e)\n")
    folder = os.path.dirname(btfgmm.__file__)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=folder))
    assert r.returncode == 0, r.stderr
    assert "btfgmm needs numpy" in r.stdout and "apt install python3-numpy" in r.stdout
    assert sys.executable in r.stdout and "docs/PYTHON.md" in r.stdout
