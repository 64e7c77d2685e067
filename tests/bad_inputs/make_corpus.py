#!/usr/bin/env python3
"""Generates the bad-input corpus of issues 14 and 37 (run by tests/bad_input_corpus.rs).

Usage: make_corpus.py --out DIR --mesh COARSE.msh --model MODEL_DIR --geo BLADE.geo

From one good coarse mesh (MSH 4.1 ASCII) and the good reduced model built from it, writes damaged
copies and bad case / settings files into DIR, and DIR/manifest.json: one entry per case with

  name     unique name
  class    case file | settings file | forced settings | forced inputs | CLI argument | output path |
           mesh | reduced model | stopped early
  args     the nlmodes command line (absolute paths)
  code     expected exit code (2 bad input, 3 stopped early; README "Exit codes")
  pattern  a regular expression the message (stdout + stderr) must match
  absent   paths (globs) that must not exist afterwards (e.g. no .tmp left)
  present  paths that must exist afterwards (partial results kept)

Every case but the "stopped early" one must fail before any computation (milliseconds), the
reduce cases after a coarse assembly (well under a second), the forced inputs after reading the
coarse model (C.mtx, F.mtx, --backbone, the orbit mesh against it; no frf.csv written).
"""

import argparse
import json
import os
import re
import shutil

BAD, STOPPED = 2, 3


class Corpus:
    def __init__(self, out):
        self.out = out
        self.cases = []

    def path(self, *parts):
        return os.path.join(self.out, *parts)

    def add(self, cls, name, args, pattern, code=BAD, absent=(), present=()):
        assert all(c["name"] != name for c in self.cases), name
        re.compile(pattern)
        self.cases.append(
            dict(
                name=name,
                cls=cls,
                args=[str(a) for a in args],
                code=code,
                pattern=pattern,
                absent=list(absent),
                present=list(present),
            )
        )

    def write(self, rel, text):
        p = self.path(rel)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        with open(p, "w") as f:
            f.write(text)
        return p


# ---------------------------------------------------------------- case files

def base_case(c, geo, extra_top="", **tables):
    """A valid coarse case; `tables` maps a table name to extra lines placed in it."""
    t = {k: v for k, v in tables.items()}
    parts = [
        f'results_dir = "{c.path("results")}"',
        extra_top,
        "[mesh]",
        f'geo = "{geo}"',
        "order = 2",
        t.pop("mesh", ""),
        "[mesh.parameters]",
        "mesh_size = 0.012",
        t.pop("mesh_parameters", ""),
        "[material]",
        t.pop("material", ""),
        "[model]",
        "fixed_interface_modes = 20",
        "linear_modes = 6",
        t.pop("model", ""),
        "[nnm]",
        "keep = [3.0, 12.0]",
        "frames = 6",
        t.pop("nnm", ""),
        "[continuation]",
        t.pop("continuation", "q_start = 0.5\nq_max = 14.0"),
        "[algorithm]",
        t.pop("algorithm", ""),
    ]
    assert not t, t
    return "\n".join(p for p in parts if p) + "\n"


def case_files(c, geo):
    def bad(name, pattern, text=None, **tables):
        p = c.write(f"cases/{name}.toml", text if text is not None else base_case(c, geo, **tables))
        c.add("case file", f"case_{name}", ["run", p], pattern)

    file_key = r"\.toml: "
    bad("unknown_top_key", "colour", base_case(c, geo, extra_top="colour = 3"))
    bad("unknown_nnm_key", "harmonix", nnm="harmonix = 3")
    bad("unknown_table", "solver", base_case(c, geo) + "[solver]\nx = 1\n")
    bad("wrong_type", "harmonics|invalid type", nnm='harmonics = "ten"')
    bad("syntax_error", "invalid TOML", "[nnm\nharmonics = 3\n")
    bad("duplicate_key", "invalid TOML|duplicate", nnm="frames = 3\nframes = 4")
    bad("mesh_order_3", file_key + r"mesh\.order = 3: expected 1 \(TET4\) or 2", text=base_case(c, geo).replace("order = 2", "order = 3"))
    bad("mesh_geo_missing", file_key + r"mesh\.geo: cannot read .*nonexistent", text=base_case(c, geo).replace(geo, "/nonexistent/blade.geo"))
    bad("mesh_unknown_parameter", r"mesh\.parameters\.wingspan: `wingspan` is not defined", mesh_parameters="wingspan = 3.0")
    bad("mesh_parameter_nan", r"mesh\.parameters\.mesh_size = NaN", text=base_case(c, geo).replace("mesh_size = 0.012", "mesh_size = nan"))
    for key, value, pat in [
        ("young", "0.0", r"material\.young = 0\.0: expected a finite value > 0"),
        ("young", "-1.0e9", r"material\.young = -1000000000\.0"),
        ("young", "inf", r"material\.young = inf"),
        ("poisson", "0.5", r"material\.poisson = 0\.5: expected -1 < poisson < 0\.5"),
        ("poisson", "-1.5", r"material\.poisson = -1\.5"),
        ("density", "0.0", r"material\.density = 0\.0"),
        ("density", "nan", r"material\.density = NaN"),
    ]:
        bad(f"material_{key}_{value}", file_key + pat, material=f"{key} = {value}")
    for name, line, pat in [
        ("clamp_empty", "clamp = []", r"model\.clamp = \[\]: expected at least one clamped group"),
        ("clamp_bad_spec", 'clamp = ["root:w"]', r"model\.clamp\[0\]: invalid constraint 'root:w'"),
        ("contact_empty", 'contact_group = ""', r"model\.contact_group = \"\": expected a physical group name"),
        ("contact_on_clamp", 'contact_group = "root"', r"model\.contact_group = \"root\": expected a group that is not clamped \(model\.clamp = \[\"root\"\]\)"),
        ("axis_zero", "rotor_axis_direction = [0.0, 0.0, 0.0]", r"model\.rotor_axis_direction = \[0\.0, 0\.0, 0\.0\]: expected a finite, non-zero"),
        ("axis_point_nan", "rotor_axis_point = [nan, 0.0, 0.0]", r"model\.rotor_axis_point = \[NaN"),
        ("gap_zero", "gap = 0.0", r"model\.gap = 0\.0: expected a finite gap > 0"),
        ("gap_negative", "gap = -2e-4", r"model\.gap = -0\.0002"),
        ("gap_inf", "gap = inf", r"model\.gap = inf"),
        ("fixed_interface_modes_0", "fixed_interface_modes = 0", r"model\.fixed_interface_modes = 0: expected at least 1"),
        ("linear_modes_0", "linear_modes = 0", r"model\.linear_modes = 0: expected at least 1"),
        ("master_word", 'master = "first"', r"model\.master = \"first\": expected \"auto\" or a reduced DOF index"),
        ("master_negative", "master = -1", r"master|invalid"),
    ]:
        text = base_case(c, geo, model=line)
        if name in ("fixed_interface_modes_0", "linear_modes_0"):
            key = line.split(" =")[0]
            text = re.sub(rf"^{key} = \d+\n", "", text, flags=re.M).replace("[model]\n", f"[model]\n{line}\n")
        bad(name, pattern=pat, text=text)
    for name, line, pat in [
        ("harmonics_0", "harmonics = 0", r"nnm\.harmonics = 0: expected at least 1"),
        ("samples_below_2N1", "samples = 20", r"nnm\.samples = 20: expected at least 2 nnm\.harmonics \+ 1 = 21"),
        ("samples_vs_harmonics", "harmonics = 70", r"nnm\.samples = 128: expected at least 2 nnm\.harmonics \+ 1 = 141"),
        ("keep_nan", "keep_nan", r"nnm\.keep\[0\] = NaN: expected an amplitude q/g0 within"),
        ("keep_negative", "keep_neg", r"nnm\.keep\[1\] = -1\.0"),
        ("keep_beyond_q_max", "keep_big", r"nnm\.keep\[0\] = 20\.0: expected .*\[0\.5, 14\]"),
        ("keep_below_q_start", "keep_small", r"nnm\.keep\[0\] = 0\.2"),
        ("frames_0", "frames0", r"nnm\.frames = 0: expected at least 2"),
        ("frames_1", "frames1", r"nnm\.frames = 1: expected at least 2"),
    ]:
        text = base_case(c, geo)
        repl = {
            "keep_nan": "keep = [nan]",
            "keep_neg": "keep = [3.0, -1.0]",
            "keep_big": "keep = [20.0]",
            "keep_small": "keep = [0.2]",
            "frames0": "frames = 0",
            "frames1": "frames = 1",
        }
        if line in repl:
            key = repl[line].split(" =")[0]
            text = re.sub(rf"^{key} = .*\n", repl[line] + "\n", text, flags=re.M)
        else:
            text = text.replace("[nnm]\n", f"[nnm]\n{line}\n")
        bad(name, pat, text=text)
    for name, lines, pat in [
        ("q_max_below_q_start", "q_start = 0.5\nq_max = 0.4", r"\[continuation\]|continuation: parameter q_max = 0\.4"),
        ("q_start_zero", "q_start = 0.0\nq_max = 14.0", r"continuation: parameter q_start = 0"),
        ("q_start_nan", "q_start = nan\nq_max = 14.0", r"continuation: parameter q_start = NaN"),
        ("step_zero", "q_max = 14.0\nstep = 0.0", r"continuation: parameter step = 0"),
        ("min_step_above_step", "q_max = 14.0\nmin_step = 0.5", r"continuation: parameter step = 0\.25 is invalid: expected min_step <= step"),
        ("max_points_0", "q_max = 14.0\nmax_points = 0", r"continuation: parameter max_points"),
        ("growth_below_1", "q_max = 14.0\ngrowth = 0.5", r"continuation: parameter growth = 0\.5"),
        ("shrink_above_1", "q_max = 14.0\nshrink = 1.5", r"continuation: parameter shrink = 1\.5"),
        ("q_max_default_is_35", "step = 0.25", r"nnm\.keep\[0\] = 36\.0: expected .*\[0\.5, 35\]"),
        ("modes_twice", "q_max = 14.0\nmodes = [0, 1, 0]", r"continuation: parameter modes = 0 is invalid: expected each mode listed once"),
        ("modes_beyond_basis", "q_max = 14.0\nmodes = [0, 25]", r"continuation\.modes\[1\] = 25: expected a linear mode index \(0-based\) below model\.fixed_interface_modes = 20"),
        ("mode_beyond_basis", "q_max = 14.0\nmode = 57", r"continuation\.mode = 57: expected a linear mode index \(0-based\) below model\.fixed_interface_modes = 20"),
    ]:
        text = base_case(c, geo, continuation=lines)
        if name == "q_max_default_is_35":
            # Deleting q_max from a present [continuation] table takes the documented 35: a kept
            # amplitude of 36 is named against [0.5, 35].
            text = re.sub(r"^keep = .*\n", "keep = [36.0]\n", text, flags=re.M)
        bad(name, pat, text=text)
    for name, line, pat in [
        ("alpha_1", "alpha = 1.0", r"algorithm: parameter alpha = 1"),
        ("beta_half", "beta = 0.5", r"algorithm: parameter beta = 0\.5"),
        ("epsilon_0", "epsilon = 0.0", r"algorithm: parameter epsilon = 0"),
        ("epsilon_negative", "epsilon = -1e-3", r"algorithm: parameter epsilon = -0\.001"),
        ("max_iterations_0", "max_iterations = 0", r"algorithm: parameter max_iterations"),
        ("stall_factor_below_1", "stall_factor = 0.5", r"algorithm: parameter stall_factor = 0\.5 is invalid: expected a finite value >= 1"),
    ]:
        bad(name, pat, algorithm=line)
    bad("name_parent", r"name = \"\.\./x\": expected a plain directory name", base_case(c, geo, extra_top='name = "../x"'))
    bad("name_empty", r"name = \"\": expected a plain directory name", base_case(c, geo, extra_top='name = ""'))
    c.add("case file", "case_missing_file", ["run", c.path("cases/none.toml")], r"cannot read the case file .*none\.toml")
    # [rotation] (issue 23): every value named before any stage runs.
    for name, lines, pat in [
        ("speed_negative", "operating_speed = -100.0", r"rotation\.operating_speed = -100\.0: expected a finite speed >= 0 \(rpm\)"),
        ("speed_nan", "operating_speed = nan", r"rotation\.operating_speed = NaN"),
        ("speed_outside_range", "operating_speed = 12000.0\ncampbell_range = [0.0, 10000.0]", r"rotation\.operating_speed = 12000\.0: expected a speed within rotation\.campbell_range = \[0, 10000\] rpm"),
        ("range_inverted", "campbell_range = [9000.0, 1000.0]", r"rotation\.campbell_range = \[9000\.0, 1000\.0\]: expected \[from, to\] rpm with 0 <= from < to"),
        ("range_negative", "campbell_range = [-10.0, 1000.0]", r"rotation\.campbell_range = \[-10\.0, 1000\.0\]"),
        ("engine_order_zero", "engine_orders = [0, 3]", r"rotation\.engine_orders = 0: expected integers 1 <= EO <= 200"),
        ("engine_order_negative", "engine_orders = [-2]", r"rotation\.engine_orders = -2: expected integers"),
        ("engine_orders_empty", "engine_orders = []", r"rotation\.engine_orders = \[\]: expected at least one engine order"),
        ("speeds_one", "campbell_speeds = 1", r"rotation\.campbell_speeds = 1: expected between 2 and 1000 speeds"),
        ("modes_zero", "campbell_modes = 0", r"rotation\.campbell_modes = 0: expected between 1 and 30 modes"),
        ("kinematics_unknown", 'kinematics = "elastic"', r"rotation\.kinematics = \"elastic\": expected \"nonlinear\" or \"linear\""),
        ("map_amplitude_zero", "map_amplitudes = [0.0]", r"rotation\.map_amplitudes = 0\.0: expected finite amplitudes q/g0 > 0"),
        ("map_speed_outside", "map_speeds = [20000.0]", r"rotation\.map_speeds = 20000\.0: expected finite speeds within rotation\.campbell_range = \[0, 10000\] rpm"),
        ("map_speed_nan", "map_speeds = [nan]", r"rotation\.map_speeds = NaN: expected finite speeds"),
        ("unknown_key", "operating_sped = 100.0", r"unknown field `operating_sped`"),
    ]:
        bad(f"rotation_{name}", pat, text=base_case(c, geo) + "[rotation]\n" + lines + "\n")
    bad("forced_load_file_in_a_case", r"forced\.load = \"file\": expected \"master\" or \"mode\" in a case: .*F\.mtx does not exist",
        text=base_case(c, geo) + "[forced]\nload = \"file\"\n")
    # [forced] load = "pressure" (issue 22, item 3): the group must be a surface of the mesh; known
    # only once the mesh exists, so these two mesh the coarse blade and fail at the reduce stage.
    pressure = '[forced]\nload = "pressure"\nload_group = "{}"\n'
    groups = r".*'root' \(dim 2\), 'tip' \(dim 2\)"
    bad("forced_pressure_on_a_volume",
        r'forced\.load_group = "blade" \(forced\.load = "pressure"\): physical group \'blade\' \(dim 3\) '
        r"is not a surface of triangles: a pressure acts on a surface group \(dim 2\); groups present:" + groups,
        text=base_case(c, geo, model='full_check = "off"') + pressure.format("blade"))
    bad("forced_pressure_missing_group",
        r'forced\.load_group = "casing" \(forced\.load = "pressure"\): no physical group named \'casing\'; '
        r"groups present:" + groups,
        text=base_case(c, geo, model='full_check = "off"') + pressure.format("casing"))
    # Issue 37: [forced] against what the case knows of the model (model.fixed_interface_modes =
    # 20), and the files the reduce stage does not write, before any stage runs.
    beyond = r"expected a linear mode index \(0-based\) below model\.fixed_interface_modes = 20"
    for name, lines, pat in [
        ("mode_beyond_basis", "mode = 500", r"forced\.mode = 500: " + beyond),
        ("load_mode_beyond_basis", "load = \"mode\"\nload_mode = 500\nmode = 0\nlevel_unit = \"N\"", r"forced\.load_mode = 500: " + beyond),
        ("damping_ratios_beyond_basis", "damping_ratios = [" + ", ".join(["0.01"] * 30) + "]",
         r"forced\.damping_ratios: 30 ratios: expected at most model\.fixed_interface_modes = 20"),
        ("damping_matrix", "damping_matrix = true", r"forced\.damping_matrix = true: expected false in a case: .*C\.mtx does not exist"),
        ("zero_damping_grazing", "damping_ratio = 0.0", file_key + r"forced\.damping_ratio = 0\.0: expected damping on the swept mode"),
        ("harmonics_huge", "harmonics = 5000", r"forced\.harmonics = 5000: expected N <= 200"),
    ]:
        bad(f"forced_{name}", pat, text=base_case(c, geo) + "[forced]\n" + lines + "\n")
    for name, lines, pat in [
        ("engine_orders_repeated", "engine_orders = [2, 3, 2]", r"rotation\.engine_orders = 2: expected each engine order listed once"),
        ("map_amplitude_beyond_q_max", "map_amplitudes = [5.0, 20.0]",
         r"rotation\.map_amplitudes = 20\.0: expected an amplitude q/g0 within \[continuation\.q_start, continuation\.q_max\] = \[0\.5, 14\]"),
        ("map_amplitude_below_q_start", "map_amplitudes = [0.1]", r"rotation\.map_amplitudes = 0\.1: expected an amplitude q/g0 within"),
        ("speed_word", "operating_speed = \"fast\"", r"invalid TOML file .*: .*operating_speed|invalid type: string \"fast\""),
        ("campbell_range_one", "campbell_range = [1000.0]", r"invalid length 1, expected an array of length 2"),
        ("engine_order_float", "engine_orders = [1.5]", r"invalid type: floating point `1\.5`, expected i64"),
        ("map_speeds_inf", "map_speeds = [inf]", r"rotation\.map_speeds = inf: expected finite speeds"),
        ("campbell_modes_31", "campbell_modes = 31", r"rotation\.campbell_modes = 31: expected between 1 and 30 modes"),
    ]:
        bad(f"rotation_{name}", pat, text=base_case(c, geo) + "[rotation]\n" + lines + "\n")
    bad("rotation_zero_axis", r"model\.rotor_axis_direction = \[0\.0, 0\.0, 0\.0\]",
        text=base_case(c, geo, model="rotor_axis_direction = [0.0, 0.0, 0.0]") + "[rotation]\n")


# ---------------------------------------------------------------- output paths and CLI

def output_paths(c, geo, mesh, model):
    a_file = c.write("outputs/a_file", "not a directory\n")
    existing = c.path("outputs/existing_dir")
    os.makedirs(existing, exist_ok=True)
    outputs = c.path("outputs")
    c.add("output path", "mesh_out_existing_dir", ["mesh", geo, "-o", existing, "--set", "mesh_size=0.02"],
          r"--out .*existing_dir: is an existing directory",
          absent=[existing + ".msh.tmp", existing + ".tmp", os.path.join(outputs, ".existing_dir.tmp-*"),
                  os.path.join(existing, "*")])
    c.add("output path", "mesh_out_under_file", ["mesh", geo, "-o", os.path.join(a_file, "m.msh")],
          r"a_file exists and is not a directory", absent=[os.path.join(a_file + "*.tmp")])
    c.add("output path", "backbone_out_file", ["backbone", model, "--out", a_file],
          r"--out: output directory .*a_file: .*exists and is not a directory")
    c.add("output path", "backbone_out_under_file", ["backbone", model, "--out", os.path.join(a_file, "sub")],
          r"a_file exists and is not a directory")
    c.add("output path", "modes_out_file", ["modes", mesh, "--fix", "root", "-o", a_file],
          r"--out: output directory .*a_file")
    c.add("output path", "reduce_out_file", ["reduce", mesh, "-o", a_file], r"--out: output directory .*a_file")
    for name, rd in [("results_dir_file", a_file), ("results_dir_under_file", os.path.join(a_file, "r"))]:
        p = c.write(f"cases/{name}.toml", base_case(c, geo).replace(f'results_dir = "{c.path("results")}"', f'results_dir = "{rd}"'))
        c.add("output path", name, ["run", p], r"results_dir: output directory .*a_file")


def cli_arguments(c, geo, mesh, model):
    out = c.path("cli_out")
    cli = lambda name, args, pat: c.add("CLI argument", name, args, pat)
    cli("no_subcommand", [], r"Usage|subcommand")
    cli("unknown_subcommand", ["frobnicate"], r"unrecognized subcommand")
    cli("unknown_flag", ["backbone", model, "-o", out, "--colour", "red"], r"unexpected argument '--colour'")
    cli("backbone_harmonics_0", ["backbone", model, "-o", out, "--harmonics", "0"], r"--harmonics = 0: expected at least 1")
    cli("backbone_samples_8", ["backbone", model, "-o", out, "--samples", "8"], r"--samples = 8: expected at least 2 nnm\.harmonics \+ 1 = 21")
    cli("backbone_q_max_low", ["backbone", model, "-o", out, "--q-max", "0.2"], r"parameter q_max = 0\.2 is invalid: expected a value > q_start")
    cli("backbone_q_max_nan", ["backbone", model, "-o", out, "--q-max", "nan"], r"parameter q_max = NaN")
    cli("backbone_q_start_negative", ["backbone", model, "-o", out, "--q-start", "-1"], r"parameter q_start = -1")
    cli("backbone_master_range", ["backbone", model, "-o", out, "--master", "99999"], r"--master 99999: expected a reduced coordinate index < \d+")
    cli("backbone_harmonics_word", ["backbone", model, "-o", out, "--harmonics", "ten"], r"invalid value 'ten'")
    cli("backbone_missing_out", ["backbone", model], r"--out")
    cli("modes_count_0", ["modes", mesh, "--fix", "root", "--modes", "0", "-o", out], r"--modes 0: expected at least 1")
    cli("modes_young_negative", ["modes", mesh, "--fix", "root", "--young", "-1", "-o", out], r"--young = -1\.0: expected a finite value > 0")
    cli("modes_poisson_07", ["modes", mesh, "--fix", "root", "--poisson", "0.7", "-o", out], r"--poisson = 0\.7: expected -1 < poisson < 0\.5")
    cli("modes_density_0", ["modes", mesh, "--fix", "root", "--density", "0", "-o", out], r"--density = 0\.0: expected a finite value > 0")
    cli("modes_sigma_nan", ["modes", mesh, "--fix", "root", "--sigma", "nan", "-o", out], r"--sigma NaN: expected a finite shift")
    cli("modes_unknown_group", ["modes", mesh, "--fix", "hub", "-o", out], r"no physical group named 'hub'; groups present: .*'root'")
    cli("modes_bad_fix_spec", ["modes", mesh, "--fix", "root:w", "-o", out], r"invalid constraint 'root:w'")
    cli("reduce_gap_0", ["reduce", mesh, "--gap", "0", "-o", out], r"--gap 0: expected a finite gap > 0")
    cli("reduce_gap_negative", ["reduce", mesh, "--gap", "-1e-4", "-o", out], r"--gap -0\.0001")
    cli("reduce_axis_zero", ["reduce", mesh, "--axis-direction", "0,0,0", "-o", out], r"--axis-point/--axis-direction: .*zero vector")
    cli("reduce_axis_two_numbers", ["reduce", mesh, "--axis-point", "1,2", "-o", out], r"expected three comma-separated numbers")
    cli("reduce_modes_0", ["reduce", mesh, "--modes", "0", "-o", out], r"--modes 0: expected at least 1")
    cli("reduce_unknown_contact", ["reduce", mesh, "--contact", "tip_rim", "--compare", "0", "-o", out], r"no physical group named 'tip_rim'; groups present: .*'tip_edge'")
    cli("reduce_contact_on_clamp", ["reduce", mesh, "--contact", "root", "--compare", "0", "-o", out], r"lies on the clamped group\(s\) 'root'")
    cli("reduce_master_range", ["reduce", mesh, "--modes", "4", "--master", "99999", "--compare", "0", "-o", out], r"master coordinate 99999 is out of range")
    cli("mesh_order_3", ["mesh", geo, "-o", c.path("cli_out.msh"), "--order", "3"], r"element order 3 is not supported")
    cli("mesh_unknown_parameter", ["mesh", geo, "-o", c.path("cli_out.msh"), "--set", "wingspan=3"], r"`wingspan` is not defined")
    cli("mesh_set_no_value", ["mesh", geo, "-o", c.path("cli_out.msh"), "--set", "mesh_size"], r"expected NAME=VALUE")
    geos = c.path("geo")
    os.makedirs(geos, exist_ok=True)
    broken = c.write("geo/broken.geo", "Point(1) = {0, 0, 0;\nfoo bar\n")
    cli("mesh_geo_syntax_error", ["mesh", broken, "-o", os.path.join(geos, "broken.msh")],
        r"gmsh failed on .*broken\.geo")
    c.cases[-1]["absent"] = [os.path.join(geos, ".broken.msh.tmp-*"), os.path.join(geos, "broken.msh")]
    flat = c.write("geo/no_volume.geo", "Point(1) = {0, 0, 0};\nPoint(2) = {1, 0, 0};\nLine(1) = {1, 2};\n")
    cli("mesh_geo_without_volume", ["mesh", flat, "-o", os.path.join(geos, "no_volume.msh")],
        r"gmsh meshed .*no_volume\.geo but the result is not a usable mesh: .*no tetrahedra")
    c.cases[-1]["absent"] = [os.path.join(geos, ".no_volume.msh.tmp-*"), os.path.join(geos, "no_volume.msh")]
    cli("mesh_missing_geo", ["mesh", c.path("none.geo"), "-o", c.path("cli_out.msh")], r"cannot read the geometry file .*none\.geo")
    cli("run_only_unknown", ["run", c.path("cases/none.toml"), "--only", "everything"], r"invalid value 'everything'")


def settings_files(c, model):
    out = c.path("settings_out")

    def bad(name, text, pat, extra=()):
        p = c.write(f"settings/{name}.toml", text)
        c.add("settings file", f"settings_{name}", ["backbone", model, "--settings", p, "-o", out, *extra], pat)

    bad("unknown_table", "[nnm]\nharmonics = 3\n", r"unknown field `nnm`")
    bad("unknown_key", "[algorithm]\nepsilom = 1e-3\n", r"unknown field `epsilom`")
    bad("epsilon_nan", "[algorithm]\nepsilon = nan\n", r"parameter epsilon = NaN")
    bad("syntax", "[algorithm\n", r"invalid TOML file .*syntax\.toml")
    bad("q_max_default_is_35", "[continuation]\nstep = 0.25\n",
        r"parameter q_max = 35 is invalid: expected a value > q_start", extra=["--q-start", "36"])
    bad("max_penalty_below_initial", "[algorithm]\nmax_penalty = 5.0\n", r"parameter max_penalty = 5")
    bad("modes_list", "[continuation]\nmodes = [0, 1]\n", r"continuation\.modes = \[0, 1\]: expected no list here: `nlmodes backbone` traces one mode")
    bad("mode_beyond_model", "[continuation]\nmode = 5000\n", r"continuation\.mode = 5000: expected a linear mode index \(0-based\) below \d+, the order of the reduced model")
    bad("step_huge", "[continuation]\nstep = 1e300\n", r"parameter step = 1e300 is invalid: expected min_step <= step <= max_step")
    c.add("settings file", "settings_missing", ["backbone", model, "--settings", c.path("settings/none.toml"), "-o", out],
          r"cannot read the settings file .*none\.toml")


def forced_settings(c, model):
    """`nlmodes forced --settings FILE`: every bad [forced] value named with file, key, value."""
    out = c.path("forced_out")

    def bad(name, text, pat, extra=()):
        p = c.write(f"forced/{name}.toml", "[forced]\n" + text)
        c.add("forced settings", f"forced_{name}", ["forced", model, "--settings", p, "-o", out, *extra], pat,
              absent=[os.path.join(out, "frf.csv")])

    bad("damping_negative", "damping_ratio = -0.01\n", r"\.toml: forced\.damping_ratio = -0\.01: expected a ratio 0 <= zeta < 1")
    bad("damping_ratios_nan", "damping_ratios = [0.01, nan]\n", r"forced\.damping_ratios = NaN")
    bad("rayleigh_negative", "rayleigh = [-1.0, 0.0]\n", r"forced\.rayleigh = \[-1\.0, 0\.0\]: expected \[alpha >= 0")
    bad("level_zero", "levels = [0.0]\n", r"forced\.levels = 0\.0: expected finite force levels > 0")
    bad("level_inf", "levels = [inf]\n", r"forced\.levels = inf: expected finite force levels > 0")
    bad("levels_empty", "levels = []\n", r"forced\.levels = \[\]: expected at least one level")
    bad("range_inverted", "range = [1.2, 0.9]\n", r"forced\.range = \[1\.2, 0\.9\]: expected a non-empty range")
    bad("range_empty", "range = [1.0, 1.0]\n", r"forced\.range = \[1\.0, 1\.0\]: expected a non-empty range")
    bad("range_negative", "range = [-0.5, 1.0]\n", r"forced\.range = \[-0\.5, 1\.0\]: expected start > 0")
    bad("harmonic_zero", "harmonic = 0\n", r"forced\.harmonic = 0: expected 1 <= h <= harmonics")
    bad("harmonics_zero", "harmonics = 0\n", r"forced\.harmonics = 0: expected >= 1")
    bad("samples_small", "harmonics = 5\nsamples = 8\n", r"forced\.samples = 8: expected 0 \(default\) or m >= 2 N \+ 1")
    bad("penalty_zero", "penalty_factor = 0.0\n", r"forced\.penalty_factor = 0\.0: expected a finite factor > 0")
    bad("unknown_key", "dampnig_ratio = 0.01\n", r"\.toml: \[forced\]: unknown field `dampnig_ratio`")
    bad("contact_word", "contact = \"soft\"\n", r"unknown variant `soft`, expected `exact` or `penalty`")
    bad("mode_beyond_model", "mode = 5000\n", r"forced\.mode = 5000: expected a linear mode index \(0-based\) below \d+")
    bad("load_mode_beyond_model", "load = \"mode\"\nload_mode = 777\n", r"forced\.load_mode = 777: expected a linear mode index")
    bad("load_direction_zero", "load = \"group\"\nload_direction = [0.0, 0.0, 0.0]\n", r"forced\.load_direction = \[0\.0, 0\.0, 0\.0\]: expected a finite, non-zero direction")
    bad("level_sweeps_negative", "level_sweeps = [-1.05]\n", r"forced\.level_sweeps = -1\.05: expected frequencies W / w_mode > 0")
    bad("level_range_inverted", "level_sweeps = [1.05]\nlevel_range = [5.0, 0.5]\n", r"forced\.level_range = \[5\.0, 0\.5\]: expected a non-empty range")
    bad("keep_negative", "keep = [-1.0]\n", r"forced\.keep = -1\.0: expected finite frequencies W / w_mode > 0")
    bad("frames_one", "frames = 1\n", r"forced\.frames = 1: expected between 2 and 1000 frames per period")
    bad("load_file_missing", "load = \"file\"\n", r"forced\.load = \"file\": .*F\.mtx: cannot read it")
    bad("load_harmonics_zero", "load = \"file\"\nload_harmonics = [0]\n", r"forced\.load_harmonics = 0: expected distinct harmonics 1 <= h <= harmonics")
    bad("load_harmonics_repeated", "load = \"file\"\nload_harmonics = [2, 2]\n", r"forced\.load_harmonics = 2: expected distinct harmonics")
    # Issue 37: what the keys alone tell.
    graze = r"expected damping on the swept mode \(forced\.mode = 0\) with forced\.level_unit = \"grazing\""
    bad("damping_zero_grazing", "damping_ratio = 0.0\n", r"\.toml: forced\.damping_ratio = 0\.0: " + graze)
    bad("damping_ratios_zero_on_mode", "damping_ratios = [0.0, 0.02]\n", r"forced\.damping_ratios\[0\] = 0\.0: " + graze)
    bad("damping_ratios_last_zero", "mode = 3\ndamping_ratios = [0.01, 0.0]\n",
        r"forced\.damping_ratios\[1\] = 0\.0: expected damping on the swept mode \(forced\.mode = 3\)")
    bad("rayleigh_zero_grazing", "rayleigh = [0.0, 0.0]\n", r"forced\.rayleigh = \[0\.0, 0\.0\]: " + graze)
    bad("rayleigh_and_ratios", "rayleigh = [1.0, 0.0]\ndamping_ratios = [0.01]\n",
        r"forced\.damping_ratios = \[0\.01\]: expected no list beside forced\.rayleigh = \[1\.0, 0\.0\]")
    bad("damping_ratios_longer_than_model", "damping_ratios = [" + ", ".join(["0.01"] * 500) + "]\n",
        r"\.toml: forced\.damping_ratios: 500 ratios: expected at most one per linear mode of the reduced model, n = \d+")
    bad("load_mode_other_grazing", "load = \"mode\"\nload_mode = 1\n",
        r"forced\.load_mode = 1: expected a linear mode index equal to forced\.mode = 0 with load = \"mode\" and\s+level_unit = \"grazing\": the pattern M phi of another mode does not drive\s+mode 0")
    bad("harmonics_huge", "harmonics = 100000\n", r"forced\.harmonics = 100000: expected N <= 200")
    bad("samples_huge", "samples = 10000000000\n", r"forced\.samples = 10000000000: expected at most 65536 time samples per period")
    bad("keep_outside_range", "keep = [1.5]\n", r"forced\.keep = 1\.5: expected a frequency W / w_mode within forced\.range = \[0\.9, 1\.2\]")
    bad("penalty_overflow", "penalty_factor = 1e306\n", r"forced\.penalty_factor = 1e306: kc = .* = inf N/m: expected a finite penalty stiffness > 0")
    bad("level_unit_word", "level_unit = \"kN\"\n", r"\.toml: \[forced\]: unknown variant `kN`, expected `N` or `grazing`")
    bad("mode_word", "mode = \"first\"\n", r"\.toml: \[forced\]: invalid type: string \"first\", expected usize\s+in `mode`")
    bad("mode_negative", "mode = -1\n", r"\.toml: \[forced\]: invalid value: integer `-1`, expected usize\s+in `mode`")
    bad("levels_scalar", "levels = 0.5\n", r"\.toml: \[forced\]: invalid type: floating point `0\.5`, expected a sequence\s+in `levels`")
    bad("load_direction_nan", "load = \"group\"\nload_direction = [nan, 0.0, 0.0]\n", r"forced\.load_direction = \[NaN, 0\.0, 0\.0\]: expected a finite, non-zero direction")
    bad("damping_ratio_one", "damping_ratio = 1.0\n", r"forced\.damping_ratio = 1\.0: expected a ratio 0 <= zeta < 1")
    bad("level_sweeps_nan", "level_sweeps = [nan]\n", r"forced\.level_sweeps = NaN: expected frequencies W / w_mode > 0")
    # Issue 39, item 3: the casing distortion.
    alone = "levels = []\n[forced.distortion]\n"
    bad("distortion_lobes_zero", alone + "lobes = 0\namplitude = 1.5\namplitude_unit = \"gap\"\n",
        r"\.toml: forced\.distortion\.lobes = 0: expected an integer 1 <= n <= 200")
    bad("distortion_amplitude_negative", alone + "amplitude = -1e-5\n",
        r"\.toml: forced\.distortion\.amplitude = -1e-5: expected a finite amplitude >= 0")
    bad("distortion_amplitude_inf", alone + "amplitude = inf\n",
        r"\.toml: forced\.distortion\.amplitude = inf: expected a finite amplitude >= 0")
    bad("distortion_amplitude_nan", alone + "amplitude = nan\n",
        r"\.toml: forced\.distortion\.amplitude = NaN: expected a finite amplitude >= 0")
    bad("distortion_phase_nan", "[forced.distortion]\namplitude = 1e-5\nphase = nan\n",
        r"\.toml: forced\.distortion\.phase = NaN: expected a finite phase \(rad\)")
    bad("distortion_harmonic_beyond_n", "[forced.distortion]\namplitude = 1e-5\nharmonic = 11\n",
        r"\.toml: forced\.distortion\.harmonic = 11: expected 1 <= h <= forced\.harmonics = 10")
    bad("distortion_unit_word", "[forced.distortion]\namplitude_unit = \"mm\"\n",
        r"unknown variant `mm`, expected `m` or `gap`")
    bad("distortion_none_without_levels", "levels = []\n[forced.distortion]\namplitude = 0.0\n",
        r"forced\.levels = \[\]: expected at least one level \(or none, with a \[forced\.distortion\] amplitude > 0")
    bad("distortion_alone_short", alone + "amplitude = 0.5\namplitude_unit = \"gap\"\n",
        r"\.toml: forced\.distortion\.amplitude = 0\.5 \(.* m\) with no load \(forced\.levels = \[\]\): expected more than the smallest gap")
    c.add("forced settings", "forced_backbone_missing",
          ["forced", model, "--backbone", c.path("forced/none.json"), "-o", out], r"--backbone .*none\.json", absent=[os.path.join(out, "frf.csv")])


def forced_inputs(c, model):
    """`nlmodes forced MODEL`: C.mtx, F.mtx, --backbone and the orbit mesh against the model (issue 37)."""
    _, K = read_mtx(os.path.join(model, "K.mtx"))
    doc = json.load(open(os.path.join(model, "model.json")))
    n = len(K)
    out = c.path("forced_inputs_out")

    def bad(name, settings, pat, files=None, edit=None, extra=()):
        d = c.path("forced_models", name)
        shutil.copytree(model, d)
        for fname, text in (files or {}).items():
            with open(os.path.join(d, fname), "w") as f:
                f.write(text)
        if edit is not None:
            edit(d)
        p = c.write(f"forced_models/{name}.toml", "[forced]\n" + settings)
        c.add("forced inputs", f"forced_input_{name}", ["forced", d, "--settings", p, "-o", out, *extra], pat,
              absent=[os.path.join(out, "frf.csv")])

    def mtx(a):
        m = len(a)
        lines = ["%%MatrixMarket matrix coordinate real symmetric", f"{m} {m} {m * (m + 1) // 2}"]
        lines += [f"{i + 1} {j + 1} {a[i][j]:.17e}" for j in range(m) for i in range(j, m)]
        return "\n".join(lines) + "\n"

    def scaled(a, f):
        return [[v * f for v in row] for row in a]

    matrix = "damping_matrix = true\n"
    small = [row[:-4] for row in scaled(K, 1e-5)[:-4]]
    bad("c_wrong_order", matrix, rf"forced\.damping_matrix = true: .*c_wrong_order/C\.mtx: damping matrix C is {n - 4}x{n - 4}, expected {n}x{n}",
        files={"C.mtx": mtx(small)})
    bad("c_negative_definite", matrix + "level_unit = \"N\"\n",
        rf"c_negative_definite/C\.mtx: damping matrix C: {n} negative eigenvalue\(s\) .*the lowest = -\S+: expected a positive semi-definite C",
        files={"C.mtx": mtx(scaled(K, -0.01))})
    indefinite = scaled(K, 1e-5)
    indefinite[0][0] = -indefinite[0][0]
    bad("c_indefinite", matrix, r"c_indefinite/C\.mtx: damping matrix C: [1-9]\d* negative eigenvalue\(s\)",
        files={"C.mtx": mtx(indefinite)})
    with_nan = mtx(scaled(K, 1e-5)).split("\n")
    assert with_nan[2].startswith("1 1 ")
    with_nan[2] = "1 1 nan"
    bad("c_nan", matrix, r"c_nan/C\.mtx: cannot read it: .*(non-finite|NaN|not finite)",
        files={"C.mtx": "\n".join(with_nan)})
    bad("c_general_asymmetric", matrix, r"c_general_asymmetric/C\.mtx: cannot read it: .*symmetric",
        files={"C.mtx": "%%MatrixMarket matrix coordinate real general\n" + f"{n} {n} {n + 1}\n"
               + "".join(f"{i + 1} {i + 1} 1.0\n" for i in range(n)) + "2 1 0.5\n"})
    bad("c_times_1e280", matrix, r"c_times_1e280/C\.mtx: the largest entry of C is \S+e2\d\d: expected at most 1e30 N s/m",
        files={"C.mtx": mtx(scaled(K, 1e280))})
    bad("c_missing", matrix, r"forced\.damping_matrix = true: .*c_missing/C\.mtx: cannot read it")
    bad("c_zero_grazing", matrix,
        r"forced\.damping_matrix = true \(.*c_zero_grazing/C\.mtx\): the swept mode \(forced\.mode = 0\) gets no damping .*expected damping on it with forced\.level_unit = \"grazing\"",
        files={"C.mtx": f"%%MatrixMarket matrix coordinate real symmetric\n{n} {n} 0\n"})
    bad("f_wrong_rows", "load = \"file\"\n", rf"forced\.load = \"file\": .*f_wrong_rows/F\.mtx: {n - 1} rows, expected the model's order n = {n}",
        files={"F.mtx": f"%%MatrixMarket matrix array real general\n{n - 1} 1\n" + "1.0\n" * (n - 1)})
    bad("f_nan", "load = \"file\"\n", r"f_nan/F\.mtx: cannot read it: .*(non-finite|NaN|not finite)",
        files={"F.mtx": f"%%MatrixMarket matrix array real general\n{n} 1\n" + "1.0\n" * (n - 1) + "nan\n"})
    bad("f_zero", "load = \"file\"\n", r"f_zero/F\.mtx: every entry is zero",
        files={"F.mtx": f"%%MatrixMarket matrix array real general\n{n} 1\n" + "0.0\n" * n})
    # --backbone: a backbone of another model (another order), of another mode, of another gap.
    w1 = 2 * 3.141592653589793 * doc["linear_frequencies_hz"][0]
    gap = sum(node["gap"] for node in doc["contact_nodes"]) / len(doc["contact_nodes"])

    def backbone(name, order, omega, g):
        point = dict(q=2 * g, omega=1.01 * omega, omega_ratio=1.01, frequency_hz=omega / 6.283185307179586,
                     contact_fraction=[0.0], powell_measure=0.0, newton_iterations=1, fold=False, jump=False,
                     truncation_warning=False, coefficients=[[0.0] * order, [1e-6] * order],
                     contact_force=[[0.0]])
        doc_b = dict(points=[point], termination="Complete", omega_linear=omega, gap_reference=g,
                     grazing_amplitude=g)
        return c.write(f"forced_models/{name}.json", json.dumps(doc_b))

    other = backbone("backbone_other_model", n - 4, w1, gap)
    bad("backbone_other_model", "", rf"--backbone .*backbone_other_model\.json: backbone point 0, harmonic 0 is {n - 4} coordinates, expected {n} \(the order of the model\)",
        extra=["--backbone", other])
    wrong_mode = backbone("backbone_other_mode", n, 3.0 * w1, gap)
    bad("backbone_other_mode", "", r"--backbone .*backbone_other_mode\.json: omega_linear = \S+ rad/s .*expected \S+ rad/s, that of the swept mode .*a backbone of another mode or model",
        extra=["--backbone", wrong_mode])
    # K - w1^2 M: the first mode becomes a rigid-body mode (the loader only warns of it).
    _, M = read_mtx(os.path.join(model, "M.mtx"))

    def unclamped(d):
        write_mtx(os.path.join(d, "K.mtx"), [[K[i][j] - w1 * w1 * M[i][j] for j in range(n)] for i in range(n)])
        p = os.path.join(d, "model.json")
        j = json.load(open(p))
        j["linear_frequencies_hz"][0] = 0.0
        json.dump(j, open(p, "w"), indent=1)
    # w1^2 then lies within rounding of 0, on either side: refused as a rigid-body mode, or as a
    # K that is not positive definite, naming the model.
    bad("rigid_mode", "level_unit = \"N\"\n",
        r"(\.toml: forced\.mode = 0: a rigid-body mode of the reduced model .*expected a vibration mode"
        r"|the reduced model .*rigid_mode: matrix K is not positive definite)",
        edit=unclamped)
    # The orbits are drawn on the mesh named in model.json: a model moved without it is refused
    # before the curves are traced (not after, with frf.csv written).
    def no_mesh(d):
        p = os.path.join(d, "model.json")
        j = json.load(open(p))
        j["mesh"]["msh_file"] = os.path.join(d, "none.msh")
        json.dump(j, open(p, "w"), indent=1)
    bad("orbit_mesh_missing", "", r"orbit_mesh_missing/model\.json: the mesh the model was reduced from: .*none\.msh.*forced\.keep_peaks = true",
        edit=no_mesh)


# ---------------------------------------------------------------- meshes

def meshes(c, mesh):
    text = open(mesh).read()
    out = c.path("mesh_out")

    def bad(name, content, pat, cmd="modes"):
        p = c.write(f"meshes/{name}.msh", content)
        if cmd == "modes":
            args = ["modes", p, "--fix", "root", "--modes", "1", "-o", out]
        else:
            args = ["reduce", p, "--compare", "0", "--modes", "4", "-o", out]
        c.add("mesh", f"mesh_{name}", args, pat)

    nodes_at = text.index("$Nodes\n")
    head = text[: nodes_at + len("$Nodes\n")]
    body = text[nodes_at + len("$Nodes\n"):].split("\n")
    # node blocks: "dim entity parametric count", then count tags, then count coordinate lines
    i, tag_coord = 1, []
    while not body[i].startswith("$EndNodes"):
        count = int(body[i].split()[3])
        tags = body[i + 1: i + 1 + count]
        for k in range(count):
            tag_coord.append((int(tags[k]), i + 1 + count + k))
        i += 1 + 2 * count
    tag, line = tag_coord[len(tag_coord) // 2]
    for name, value in [("coordinate_nan", "nan"), ("coordinate_inf", "inf"), ("coordinate_minus_inf", "-inf")]:
        b = list(body)
        x = b[line].split()
        x[1] = value
        b[line] = " ".join(x)
        bad(name, head + "\n".join(b), rf"coordinate_.*\.msh: node {tag} has a non-finite coordinate")

    # Two tip_edge point elements on one mesh node (issue 14: 23 contact nodes instead of 24).
    elements = text[text.index("$Elements\n"):]
    point_blocks = re.findall(r"^0 (\d+) 15 1 ?\n(\d+) (\d+) ?\n", elements, flags=re.M)
    (e1, el1, n1), (e2, el2, n2) = point_blocks[0], point_blocks[1]
    dup = re.sub(rf"^0 {e2} 15 1 ?\n{el2} {n2} ?\n", f"0 {e2} 15 1\n{el2} {n1}\n", text, count=1, flags=re.M)
    assert dup != text
    bad("tip_edge_duplicate_node", dup,
        rf"node {n1} appears in 2 point elements of the physical group 'tip_edge'", cmd="reduce")
    bad("tip_edge_renamed", text.replace('"tip_edge"', '"tip_rim"'),
        r"no physical group named 'tip_edge'; groups present: .*'tip_rim'", cmd="reduce")
    bad("truncated", text[: len(text) // 2], r"cannot parse MSH file|truncated|missing")
    bad("empty", "", r"not a gmsh MSH file|empty")
    bad("garbage", "hello world\n" * 10, r"not a gmsh MSH file")
    bad("msh22", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n", r"2\.2")
    # an element that names a node tag absent from $Nodes
    m = re.search(r"^3 (\d+) 11 (\d+)\n(\d+) (\d+) ", elements, flags=re.M)
    assert m, "no TET10 block"
    first = m.group(0)
    dangling = text.replace(first, first[: -len(m.group(4)) - 1] + "99999999 ", 1)
    bad("dangling_node_tag", dangling, r"refers to node tag 99999999, which is not in \$Nodes")
    c.add("mesh", "mesh_missing", ["modes", c.path("meshes/none.msh"), "--fix", "root", "-o", out],
          r"cannot read mesh file .*none\.msh")


# ---------------------------------------------------------------- reduced models

def read_mtx(path):
    lines = open(path).read().split("\n")
    header = [l for l in lines if l.startswith("%")]
    rest = [l for l in lines if l and not l.startswith("%")]
    n = int(rest[0].split()[0])
    a = [[0.0] * n for _ in range(n)]
    for l in rest[1:]:
        i, j, v = l.split()
        i, j, v = int(i) - 1, int(j) - 1, float(v)
        a[i][j] = v
        a[j][i] = v
    return header, a


def write_mtx(path, a):
    n = len(a)
    lines = ["%%MatrixMarket matrix coordinate real symmetric", f"{n} {n} {n * (n + 1) // 2}"]
    for j in range(n):
        for i in range(j, n):
            lines.append(f"{i + 1} {j + 1} {a[i][j]:.17e}")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def reduced_models(c, model):
    _, K = read_mtx(os.path.join(model, "K.mtx"))
    _, M = read_mtx(os.path.join(model, "M.mtx"))
    doc = json.load(open(os.path.join(model, "model.json")))
    n = len(K)

    def bad(name, pat, k=None, m=None, js=None, edit=None):
        d = c.path("models", name)
        shutil.copytree(model, d)
        if k is not None:
            write_mtx(os.path.join(d, "K.mtx"), k)
        if m is not None:
            write_mtx(os.path.join(d, "M.mtx"), m)
        if js is not None:
            with open(os.path.join(d, "model.json"), "w") as f:
                json.dump(js, f, indent=1)
        if edit is not None:
            edit(d)
        c.add("reduced model", f"model_{name}", ["backbone", d, "-o", c.path("model_out")], pat)

    def copy(a):
        return [row[:] for row in a]

    def scaled(a, s):
        return [[v * s for v in row] for row in a]

    def doc_with(fn):
        d = json.loads(json.dumps(doc))
        fn(d)
        return d

    # Issue 14's examples.
    ms = copy(M)
    i, j = n - 2, n - 1  # rows/columns j made proportional to i: singular, positive diagonal
    s = (M[j][j] / M[i][i]) ** 0.5
    for r in range(n):
        ms[r][j] = ms[j][r] = M[r][i] * s
    ms[j][j] = M[i][i] * s * s
    bad("mass_singular_positive_diagonal", r"M\.mtx: M is (not positive definite|singular)", m=ms)
    bad("stiffness_times_1e150", r"K\.mtx: the largest entry of K is \S+e1[5-6]\d: expected between 1e-30 and 1e30", k=scaled(K, 1e150))
    bad("mass_times_1e-250", r"M\.mtx: the largest entry of M is .*e-2\d\d", m=scaled(M, 1e-250))
    bad("gap_1e-300", r"model\.json: contact node 0 .*gap 1e-300 m is below",
        js=doc_with(lambda d: d["contact_nodes"][0].update(gap=1e-300)))
    # Matrices.
    kn = copy(K)
    kn[0][0] = -kn[0][0]
    bad("stiffness_indefinite", r"K\.mtx: K is not positive semi-definite", k=kn)
    mz = copy(M)
    mz[3][3] = 0.0
    bad("mass_zero_diagonal", r"M\.mtx.*(diagonal entry 3 of M|not positive definite)", m=mz)
    bad("mass_negative", r"M\.mtx.*(diagonal entry 0 of M|not positive definite)", m=scaled(M, -1.0))
    bad("mass_mismatch_size", r"same order", m=[row[:-1] for row in M[:-1]])

    def edit_file(fname, fn):
        def go(d):
            p = os.path.join(d, fname)
            with open(p) as f:
                t = f.read()
            with open(p, "w") as f:
                f.write(fn(t))
        return go

    bad("stiffness_general_asymmetric", r"K\.mtx|not symmetric",
        edit=edit_file("K.mtx", lambda t: "%%MatrixMarket matrix coordinate real general\n2 2 3\n1 1 1\n2 1 1\n2 2 1\n"))
    bad("stiffness_nan_entry", r"K\.mtx.*(non-finite|NaN|not finite)",
        edit=edit_file("K.mtx", lambda t: re.sub(r"^1 1 \S+$", "1 1 nan", t, count=1, flags=re.M)))
    bad("stiffness_garbage_header", r"K\.mtx", edit=edit_file("K.mtx", lambda t: "hello\n" + t))
    bad("stiffness_truncated", r"K\.mtx", edit=edit_file("K.mtx", lambda t: t[: len(t) // 2]))
    bad("stiffness_missing", r"cannot open .*K\.mtx", edit=lambda d: os.remove(os.path.join(d, "K.mtx")))
    bad("model_json_missing", r"cannot read .*model\.json", edit=lambda d: os.remove(os.path.join(d, "model.json")))
    bad("model_json_not_json", r"model\.json", edit=edit_file("model.json", lambda t: t[: len(t) // 3]))
    # model.json entries.
    bad("unknown_field", r"unknown field `colour`", js=doc_with(lambda d: d.update(colour="red")))
    bad("n_mismatch", rf"n = {n + 1} but", js=doc_with(lambda d: d.update(n=n + 1)))
    bad("format_version_2", r"format_version 2 is not supported", js=doc_with(lambda d: d.update(format_version=2)))
    bad("units_changed", r"units are", js=doc_with(lambda d: d.update(units="mm")))
    bad("contact_empty", r"contact node list is empty", js=doc_with(lambda d: d.update(contact_nodes=[])))
    bad("contact_dof_duplicate", r"contact node 1 .*DOF index \d+ is already used by contact node 0",
        js=doc_with(lambda d: d["contact_nodes"][1].update(dofs=d["contact_nodes"][0]["dofs"])))
    bad("contact_dof_out_of_range", rf"DOF index {n + 5} is out of range",
        js=doc_with(lambda d: d["contact_nodes"][2]["dofs"].__setitem__(0, n + 5)))
    bad("radial_not_unit", r"contact node 0 .*radial vector .* has length .*must be a unit vector",
        js=doc_with(lambda d: d["contact_nodes"][0].update(radial=[1.0, 1.0, 0.0])))
    bad("radial_zero", r"must be a unit vector", js=doc_with(lambda d: d["contact_nodes"][4].update(radial=[0.0, 0.0, 0.0])))
    bad("gap_zero", r"gap 0 m must be finite and > 0", js=doc_with(lambda d: d["contact_nodes"][1].update(gap=0.0)))
    bad("gap_negative", r"gap -0\.0002 m must be finite and > 0", js=doc_with(lambda d: d["contact_nodes"][1].update(gap=-2e-4)))
    bad("contact_same_position", r"contact node 0 .* and contact node 1 .* are at the same position",
        js=doc_with(lambda d: d["contact_nodes"][1].update(position=d["contact_nodes"][0]["position"],
                                                           radial=d["contact_nodes"][0]["radial"])))
    bad("master_out_of_range", rf"master coordinate {n} is out of range", js=doc_with(lambda d: d["master"].update(dof=n)))
    bad("frequencies_descending", r"must be finite and ascending",
        js=doc_with(lambda d: d.update(linear_frequencies_hz=list(reversed(d["linear_frequencies_hz"])))))
    bad("axis_not_unit", r"rotor axis direction \[2\.0, 0\.0, 0\.0\] has length 2 \(must be a unit vector\)",
        js=doc_with(lambda d: d["rotor_axis"].update(direction=[2.0, 0.0, 0.0])))
    # The recovery file named in model.json (`nlmodes run` writes the compact recovery.q24).
    recovery = json.load(open(os.path.join(model, "model.json")))["recovery"]["file"]
    bad("recovery_truncated", re.escape(recovery) + r".*bytes",
        edit=lambda d: open(os.path.join(d, recovery), "r+b").truncate(1000))


def stopped_early(c, model):
    """A backbone limited to 2 points stops before q_max: exit 3, results kept, reason printed."""
    p = c.write("settings/two_points.toml", "[continuation]\nmax_points = 2\n")
    out = c.path("stopped_out")
    c.add("stopped early", "backbone_max_points_2",
          ["backbone", model, "--settings", p, "--harmonics", "3", "--samples", "32", "-o", out],
          r"the backbone stopped early at q/g0 = .*MaxPoints.*backbone\.csv", code=STOPPED,
          present=[os.path.join(out, "backbone.csv"), os.path.join(out, "backbone.json")])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--mesh", required=True)
    ap.add_argument("--model", required=True)
    ap.add_argument("--geo", required=True)
    a = ap.parse_args()
    c = Corpus(os.path.abspath(a.out))
    os.makedirs(c.out, exist_ok=True)
    geo, mesh, model = (os.path.abspath(p) for p in (a.geo, a.mesh, a.model))
    case_files(c, geo)
    settings_files(c, model)
    forced_settings(c, model)
    forced_inputs(c, model)
    cli_arguments(c, geo, mesh, model)
    output_paths(c, geo, mesh, model)
    meshes(c, mesh)
    reduced_models(c, model)
    stopped_early(c, model)
    with open(c.path("manifest.json"), "w") as f:
        json.dump(c.cases, f, indent=1)
    counts = {}
    for case in c.cases:
        counts[case["cls"]] = counts.get(case["cls"], 0) + 1
    for k, v in counts.items():
        print(f"{k}: {v}")
    print(f"total: {len(c.cases)}")


if __name__ == "__main__":
    main()
