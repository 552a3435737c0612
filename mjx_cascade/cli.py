"""`mjx-cascade`: info, train, eval, robustness, benchmark, revise, export, sim2sim and play from the command line.

The command line only parses and validates; every command calls the library functions that
notebooks and tests call. Bad input ends with one line on stderr and exit status 2, before
anything is written.
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
from pathlib import Path

import mjx_cascade  # noqa: F401  (sets the XLA CPU flag before JAX starts)
from mjx_cascade import config as config_lib
from mjx_cascade.config import ConfigError

EXIT_USAGE = 2


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, no usage dump, and where to look
        raise ConfigError(f"{message} (see {self.prog} --help)")


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        return args.func(args)
    except ConfigError as e:
        print(f"mjx-cascade: error: {e}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("mjx-cascade: interrupted; rerun the same command to resume", file=sys.stderr)
        return 130


def build_parser() -> Parser:
    p = Parser(prog="mjx-cascade", description="RL cascade motion policies for bipedal walking on MJX.",
               epilog="Each command has its own --help with examples.")
    p.add_argument("--version", action="version", version=f"mjx-cascade {mjx_cascade.__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=Parser)
    for add in (_add_info, _add_train, _add_eval, _add_robustness, _add_benchmark, _add_revise, _add_export, _add_sim2sim, _add_play):
        add(sub)
    return p


ROBOT_CHOICES = list(config_lib.ROBOTS)
MODEL_HELP = "robot MJCF (required for Digit: its digit-v3.xml; Cassie: the menagerie's by default)"
POLICY_HELP = ("a run's --out (its latest generation), one saved generation (runs/X/checkpoints/300), "
               "or a policy directory (default: the shipped policy)")
IMPL_HELP = ("physics backend: jax, warp (NVIDIA GPUs), mujoco (MuJoCo's C engine, threaded: CPUs) or auto, "
             "warp where it can run, else jax (default: auto)")


def _command(sub, name: str, help: str, examples: str) -> Parser:
    """A subcommand whose --help ends with its examples."""
    return sub.add_parser(name, help=help, description=help[0].upper() + help[1:] + ".",
                          epilog="examples:\n" + examples, formatter_class=argparse.RawDescriptionHelpFormatter)


@functools.cache
def _robot_configs() -> dict[str, config_lib.Config]:
    """Every robot's shipped config, read once for all help texts."""
    return {r: config_lib.robot_config(r) for r in ROBOT_CHOICES}


def _default(key: str) -> str:
    """Each robot's setting for `key`, for help texts: "cassie 320, digit 50"."""
    values = {r: config_lib.get(cfg, key) for r, cfg in _robot_configs().items()}
    if len(set(map(repr, values.values()))) == 1:
        return f"default {next(iter(values.values()))}"
    return "default " + ", ".join(f"{r} {v}" for r, v in values.items())


def _add_info(sub) -> None:
    info = _command(sub, "info", "policy and robot facts, or a checkpoint's",
                    "  mjx-cascade info --robot cassie\n  mjx-cascade info --checkpoint runs/cassie --json\n")
    src = info.add_mutually_exclusive_group(required=True)
    src.add_argument("--robot", choices=ROBOT_CHOICES, help="the robot's policy shape and settings")
    src.add_argument("--checkpoint", metavar="DIR", help="a run's --out or a policy directory")
    info.add_argument("--model", metavar="PATH", help=MODEL_HELP)
    info.add_argument("--json", action="store_true", help="print the facts as JSON")
    info.set_defaults(func=cmd_info)


def _add_train(sub) -> None:
    train = _command(sub, "train", "train a policy with ES; rerun the same command to resume",
                     "  mjx-cascade train --robot cassie --out runs/cassie\n"
                     "  mjx-cascade train --robot cassie --out runs/smoke --generations 2 --population 4 "
                     "--episode-seconds 0.5\n"
                     "  mjx-cascade train --robot cassie --out runs/cassie --logger tensorboard --eval-every 20\n"
                     "  mjx-cascade train --robot digit --model PATH/digit-v3.xml --out runs/digit --set es.sigma=0.05\n")
    src = train.add_mutually_exclusive_group(required=True)
    src.add_argument("--config", metavar="FILE", help="YAML config: `robot` plus overrides of its settings")
    src.add_argument("--robot", choices=ROBOT_CHOICES, help="train with the robot's shipped config")
    train.add_argument("--out", required=True, metavar="DIR",
                       help="run directory: checkpoints/, metrics.jsonl, learning_curve.png, config.yaml")
    train.add_argument("--model", metavar="PATH", help=MODEL_HELP)
    train.add_argument("--init", metavar="POLICY",
                       help="warm-start from a policy: a run's --out or a policy directory "
                            "(a run that has a checkpoint resumes instead)")
    for flag, key, kind, what in TRAIN_FLAGS:
        train.add_argument(flag, type=kind, help=f"{what}; sets {key} ({_default(key)})")
    train.add_argument("--impl", choices=config_lib.IMPLS, help=IMPL_HELP + "; sets physics.impl")
    train.add_argument("--cpu-devices", metavar="N|auto",
                       help="split the CPU into N JAX devices that share the population; about 2x for Cassie "
                            "on 2 cores (default: auto, one per core, as many as divide the population and "
                            "the robot allows; a count already in XLA_FLAGS is kept)")
    train.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                       help="any config setting, e.g. --set es.sigma=0.05 (repeatable)")
    train.add_argument("--accept-changes", action="store_true",
                       help="resume a run whose config differs from its checkpoint's (the change is recorded)")
    train.add_argument("--no-progress", action="store_true", help="no progress bar (the default off a terminal)")
    train.add_argument("--logger", action="append", default=[], metavar="KIND",
                       help="also log every metrics row to tensorboard (DIR/tensorboard/) or wandb; repeatable "
                            "or comma-separated (default: none)")
    train.set_defaults(func=cmd_train)


# the shortcuts for the settings changed most: (flag, config key, type, help)
TRAIN_FLAGS = (
    ("--generations", "train.generations", int, "generations to train to"),
    ("--population", "es.population", int, "ES population, antithetic pairs included (even)"),
    ("--episode-seconds", "episode.seconds", float, "length of each training episode, s"),
    ("--seed", "seed", int, "seed of the run's every random draw"),
    ("--checkpoint-every", "train.checkpoint_every", int, "generations between checkpoints"),
    ("--eval-every", "train.eval_every", int, "generations between checks of the ES mean on the robot's val "
                                              "profiles, the best kept in DIR/best/ (0: none)"),
)


def _add_simulation_args(parser: argparse.ArgumentParser, mjx: bool = True) -> None:
    """The policy, model, output and physics options `eval`, `robustness` and `sim2sim` share;
    `mjx`: the command runs MJX (and takes --impl)."""
    parser.add_argument("--robot", choices=ROBOT_CHOICES,
                        help="the robot (default: the --checkpoint's; with neither, required)")
    parser.add_argument("--checkpoint", metavar="DIR", help=POLICY_HELP + ", or a bundle (export)")
    parser.add_argument("--model", metavar="PATH", help=MODEL_HELP)
    parser.add_argument("--out", required=True, metavar="DIR", help="directory for the results (created)")
    parser.add_argument("--dt", type=float, help=f"physics time step, s (default {config_lib.PAPER_DT}, the "
                                                   "paper's 2 kHz loop, unless --set physics.dt)")
    if mjx:
        parser.add_argument("--impl", choices=config_lib.IMPLS, help=IMPL_HELP)
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="change a controller or physics setting of the policy's config (gait.*, "
                             "regulators.*, physics.*), e.g. --set regulators.k_phr=0.4 (repeatable)")


def _add_eval(sub) -> None:
    ev = _command(sub, "eval", "run scenarios with a trained policy: metrics, plots and video",
                  "  mjx-cascade eval --robot cassie --scenario speed_profile --out eval/speed\n"
                  "  mjx-cascade eval --checkpoint runs/cassie --scenario push slope_up my.json --out eval/run\n")
    _add_simulation_args(ev)
    ev.add_argument("--scenario", required=True, nargs="+", metavar="NAME|FILE",
                    help="scenario files or the names of shipped ones (speed_profile, push, slope_up, "
                         "slope_down, rough, limit_cycle); several run in one batch into --out/<name>/")
    ev.add_argument("--no-video", action="store_true", help="skip rendering the video")
    ev.set_defaults(func=cmd_eval)


def _add_robustness(sub) -> None:
    rob = _command(sub, "robustness", "success rates against pushes, slopes, rough ground and mass error",
                   "  mjx-cascade robustness --robot cassie --out results/robustness\n"
                   "  mjx-cascade robustness --checkpoint runs/cassie --axes push slope --trials 4 --out rob\n"
                   "  mjx-cascade robustness --checkpoint runs/cassie --impl mujoco --axes push --push-forces 125 150 \\\n"
                   "      --push-directions forward backward --set regulators.k_neutral_x=0.8 --no-figures --out rob_nx08\n")
    _add_simulation_args(rob)
    rob.add_argument("--axes", nargs="+", metavar="AXIS", help="any of push slope rough mass (default: all)")
    rob.add_argument("--trials", type=int, help="trials per cell (default 10)")
    rob.add_argument("--seconds", type=float, help="length of each trial, s (default 10)")
    rob.add_argument("--push-forces", nargs="+", type=float, metavar="N",
                     help="push forces, N (default 0 25 50 75 100 125 150)")
    rob.add_argument("--push-directions", nargs="+", metavar="DIR",
                     help="any of forward backward left right (default: all)")
    rob.add_argument("--no-figures", action="store_true", help="write only robustness.json and robustness.md")
    rob.set_defaults(func=cmd_robustness)


def _add_benchmark(sub) -> None:
    bench = _command(sub, "benchmark", "the walking bar and command-step response times on a profile set, "
                     "into one result file",
                     "  mjx-cascade benchmark walking --robot cassie --profiles val --out results/cassie_val.json\n"
                     "  mjx-cascade benchmark walking --robot cassie --profiles steps --out results/cassie_steps.json\n"
                     "  mjx-cascade benchmark walking --checkpoint runs/cassie --scenario my.json --out r.json\n")
    bench.add_argument("what", choices=("walking",), help="the benchmark (the robustness sweep is `robustness`)")
    bench.add_argument("--robot", choices=ROBOT_CHOICES,
                       help="the robot (default: the --checkpoint's; with neither, required)")
    bench.add_argument("--checkpoint", metavar="DIR", help=POLICY_HELP)
    bench.add_argument("--model", metavar="PATH", help=MODEL_HELP)
    which = bench.add_mutually_exclusive_group(required=True)
    which.add_argument("--profiles", choices=profiles_names(),
                       help="a profile set by role (configs/sets.yaml: dev, val, test), the command steps, "
                            "or the starts from standing into the ranges' corners")
    which.add_argument("--scenario", nargs="+", metavar="NAME|FILE", help="scenario files or shipped names")
    bench.add_argument("--out", required=True, metavar="FILE", help="the result file (JSON)")
    bench.add_argument("--dt", type=float, help=f"physics time step, s (default {config_lib.PAPER_DT}, the paper's)")
    bench.add_argument("--simulator", choices=("mjx", "mujoco"), default="mjx",
                       help="MJX in the evaluation's batches, or MuJoCo's C engine one profile at a time "
                            "(default: mjx)")
    bench.set_defaults(func=cmd_benchmark)


def profiles_names() -> tuple[str, ...]:
    from mjx_cascade import profiles

    return profiles.ROLES + tuple(profiles.NAMED) + profiles.test_sets()


def _add_revise(sub) -> None:
    rev = _command(sub, "revise", "record a controller setting changed after training, with its reason",
                   "  mjx-cascade revise --policy runs/cassie/policy --set regulators.k_phr=0.4 "
                   "--reason \"val: 20/20 vs 18/20\"\n")
    rev.add_argument("--policy", required=True, metavar="DIR", help="a policy directory (params.npz, record.json)")
    rev.add_argument("--set", action="append", required=True, metavar="KEY=VALUE",
                     help="the controller setting the policy runs with from now on (repeatable)")
    rev.add_argument("--reason", required=True, help="why, with the evidence")
    rev.add_argument("--date", help="when the change was decided (default: today)")
    rev.set_defaults(func=cmd_revise)


def _add_export(sub) -> None:
    ex = _command(sub, "export", "write a policy as a self-contained bundle for running it outside the trainer",
                  "  mjx-cascade export --robot cassie --out bundles/cassie\n"
                  "  mjx-cascade export --checkpoint runs/cassie --out bundles/mine\n")
    src = ex.add_mutually_exclusive_group(required=True)
    src.add_argument("--robot", choices=ROBOT_CHOICES, help="the robot's shipped policy")
    src.add_argument("--checkpoint", metavar="DIR", help=POLICY_HELP)
    ex.add_argument("--model", metavar="PATH", help=MODEL_HELP)
    ex.add_argument("--out", required=True, metavar="DIR", help="the bundle: contract.json and weights.npz (docs/bundle.md)")
    ex.set_defaults(func=cmd_export)


def _add_sim2sim(sub) -> None:
    s2s = _command(sub, "sim2sim", "run scenarios in MuJoCo's C engine with the policy: eval's files, no MJX",
                   "  mjx-cascade sim2sim --robot cassie --scenario speed_profile --out s2s/speed\n"
                   "  mjx-cascade sim2sim --bundle bundles/cassie --scenario push rough --out s2s/run\n")
    _add_simulation_args(s2s, mjx=False)
    s2s.add_argument("--bundle", metavar="DIR", help="a bundle written by export (instead of --checkpoint)")
    s2s.add_argument("--scenario", required=True, nargs="+", metavar="NAME|FILE", help="as for eval")
    s2s.add_argument("--no-video", action="store_true", help="skip rendering the video")
    s2s.set_defaults(func=cmd_sim2sim)


PLAY_KEYS = ("keys (shown on screen):\n"
             "  Up / Down            forward velocity +/- 0.1 m/s\n"
             "  Left / Right         sideways velocity +/- 0.05 m/s (to the left / right)\n"
             "  Page Up / Page Down  heading +/- 0.1 rad (turn left / right)\n"
             "  Home                 zero velocity (step in place)\n"
             "  Delete               reset the robot to standing at the origin\n"
             "  Ctrl + right drag    push the robot (the viewer's perturbation)")


def _add_play(sub) -> None:
    play = _command(sub, "play", "walk the policy in MuJoCo's interactive viewer in real time, steered by keys",
                    "  mjx-cascade play --robot cassie\n  mjx-cascade play --bundle bundles/cassie\n\n" + PLAY_KEYS + "\n")
    play.add_argument("--robot", choices=ROBOT_CHOICES, help="the robot (default: the --checkpoint's or --bundle's)")
    src = play.add_mutually_exclusive_group()
    src.add_argument("--checkpoint", metavar="DIR", help=POLICY_HELP)
    src.add_argument("--bundle", metavar="DIR", help="a bundle written by export")
    play.add_argument("--model", metavar="PATH", help=MODEL_HELP)
    play.add_argument("--dt", type=float, help=f"physics time step, s (default {config_lib.PAPER_DT})")
    play.add_argument("--seconds", type=float, help="close after this much simulated time (default: when the window closes)")
    play.set_defaults(func=cmd_play)


def _emit(payload: dict, as_json: bool) -> None:
    if as_json:
        print(json.dumps(payload, indent=2))
    else:
        for key, value in payload.items():
            print(f"{key}: {value}")


def cmd_info(args: argparse.Namespace) -> int:
    from mjx_cascade import checkpoint, policies, robots

    if args.checkpoint:
        meta, params = policies.read(args.checkpoint)
        _emit({
            "robot": meta["robot"],
            "generation": meta["generation"],
            "params_sha256": checkpoint.params_sha256(params),
            "policy_params": int(params.shape[0]),
            "action_dim": meta["action_dim"],
            "physics_steps": meta["physics_steps"],
            "wall_clock_s": meta["wall_clock_s"],
            "devices": meta["devices"],
            "device_kind": meta["device_kind"],
            "impl": meta["impl"],
        }, args.json)
        return 0
    from mjx_cascade import policy

    cfg = config_lib.robot_config(args.robot)
    definition = robots.get(args.robot)
    # the shapes need no model file, so a robot without a default model reports one only when asked for
    asked = robots.requested_model(definition, args.model)
    model = robots.model_path(definition, asked) if (asked or not definition.model_required) else None
    actions, params = policy.size(cfg, len(definition.learned))
    _emit({
        "robot": args.robot,
        "state_dim": 6,
        "action_dim": actions,
        "policy_params": params,
        "learned_joints": [f"{role}_{joint}" for role, joint in definition.learned],
        "bezier_order": cfg.gait.bezier_order,
        "dt": cfg.physics.dt,
        "step_time": cfg.gait.step_time,
        "population": cfg.es.population,
        "model": str(model) if model else (None if definition.model_required else "default"),
    }, args.json)
    return 0


def training_config(args: argparse.Namespace) -> config_lib.Config:
    cfg = config_lib.load(args.config) if args.config else config_lib.robot_config(args.robot)
    overrides = {}
    for flag, key in [(f, k) for f, k, _, _ in TRAIN_FLAGS] + [("--impl", "physics.impl")]:
        value = getattr(args, flag[2:].replace("-", "_"))
        if value is not None:
            overrides[key] = value
    overrides.update(config_lib.parse_assignments(args.set))
    return cfg.override(**overrides) if overrides else cfg


def cmd_train(args: argparse.Namespace) -> int:
    from mjx_cascade import _xla, loggers, physics, robots, train

    cfg = training_config(args)
    log_to = loggers.parse(args.logger)
    split = args.cpu_devices
    if split is None and not _xla.cpu_split_given() and not _xla.cpu_backend_started():
        split = "auto"  # both cores of a laptop by default; a split in XLA_FLAGS or a running JAX is kept
    if split is not None:  # before anything starts JAX
        try:
            devices = train.cpu_device_count(cfg, split)
        except ValueError as e:
            raise ConfigError(str(e)) from None
        train.check_devices(cfg, devices, "cpu")
        _xla.split_cpu(devices)
    model = robots.model_path(robots.get(cfg.robot), args.model)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {out} exists and is not a directory")
    train.check_resume(cfg, out, args.accept_changes)  # before the slow start: a refusal is at once
    physics.resolve_impl(cfg.physics.impl)  # an impossible --impl is refused before anything is written
    _xla.enable_compilation_cache()
    summary = train.train(cfg, out, model_path=str(model) if model else None,
                          progress=None if not args.no_progress else False, init=args.init,
                          accept_changes=args.accept_changes, log_to=log_to)
    print(json.dumps(summary))
    return 0


def _headless_gl() -> None:
    """Let MuJoCo render without a display (EGL) unless the user chose a backend; it reads
    `MUJOCO_GL` once, when first imported."""
    import ctypes.util
    import os

    if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY") and ctypes.util.find_library("EGL"):
        os.environ["MUJOCO_GL"] = "egl"


def _policy_args(args: argparse.Namespace, settings: dict) -> str | None:
    """Validate `--bundle` (it becomes the `--checkpoint`), `--robot` (or take it from the
    policy), `--dt` (default the paper's, unless `settings` set physics.dt) and `--model`;
    returns the model path."""
    from mjx_cascade import bundle, robots

    if getattr(args, "bundle", None):
        if args.checkpoint:
            raise ConfigError("give --checkpoint or --bundle, not both")
        if not bundle.is_bundle(args.bundle):
            raise ConfigError(f"--bundle {args.bundle} holds no bundle (contract.json and weights.npz)")
        args.checkpoint = args.bundle
    if args.robot is None:
        if args.checkpoint is None:
            raise ConfigError("give --robot, or a --checkpoint to take the robot from (see --help)")
        args.robot = _source_robot(args.checkpoint)
    if args.dt is not None and args.dt <= 0:
        raise ConfigError("--dt must be positive")
    if args.dt is None and "physics.dt" not in settings:
        args.dt = config_lib.PAPER_DT
    model = robots.model_path(robots.get(args.robot), args.model)
    return str(model) if model else None


def _simulation_args(args: argparse.Namespace) -> tuple[str | None, Path, dict]:
    """`_policy_args`, `--set` and `--out` of eval, robustness and sim2sim; returns
    `(model path, out, settings)`."""
    from mjx_cascade import _xla

    settings = config_lib.parse_assignments(args.set)
    model = _policy_args(args, settings)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {out} exists and is not a directory")
    _xla.enable_compilation_cache()
    return model, out, settings


def _source_robot(path: str) -> str:
    """The robot of a bundle, policy directory or checkpoint."""
    from mjx_cascade import bundle, policies

    return bundle.load(path).config.robot if bundle.is_bundle(path) else policies.read(path)[0]["robot"]


def cmd_eval(args: argparse.Namespace) -> int:
    if not args.no_video:
        _headless_gl()
    from mjx_cascade import evaluate, progress, scenario

    scenarios = [scenario.load(f) for f in args.scenario]
    model, out, settings = _simulation_args(args)
    metrics = evaluate.evaluate(args.robot, scenarios, out, checkpoint_dir=args.checkpoint, model_path=model,
                                dt=args.dt, impl=args.impl, video=not args.no_video, settings=settings,
                                progress=progress.Report("eval"))
    return _report(args, metrics, out)


def _report(args: argparse.Namespace, metrics: list[dict], out: Path) -> int:
    """eval's and sim2sim's verdicts on stdout."""
    if args.json:
        print(json.dumps(metrics[0] if len(metrics) == 1 else metrics, indent=2))
        return 0
    for m in metrics:
        verdict = "passed" if m["passed"] else "failed"
        if m["fell"]:
            verdict += f", fell at {m['fall_time']:.2f} s"
        print(f"{args.robot} / {m['scenario']['name']}: {verdict}")
    for note in dict.fromkeys(m["video"] for m in metrics
                              if m.get("video", "video.gif") not in ("video.mp4", "video.gif")):
        print(note)  # why there is no video, once
    if len(metrics) > 1:
        print(f"passed {sum(m['passed'] for m in metrics)} of {len(metrics)}")
    print(f"wrote {out}")
    return 0


def cmd_sim2sim(args: argparse.Namespace) -> int:
    if not args.no_video:
        _headless_gl()
    from mjx_cascade import progress, scenario, sim2sim

    scenarios = [scenario.load(f) for f in args.scenario]
    model, out, settings = _simulation_args(args)
    metrics = sim2sim.sim2sim(args.robot, scenarios, out, checkpoint_dir=args.checkpoint, model_path=model,
                              dt=args.dt, video=not args.no_video, settings=settings,
                              progress=progress.Report("sim2sim"))
    return _report(args, metrics, out)


def cmd_export(args: argparse.Namespace) -> int:
    from mjx_cascade import bundle, robots

    robot = args.robot or _source_robot(args.checkpoint)
    model = robots.model_path(robots.get(robot), args.model)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {out} exists and is not a directory")
    dest = bundle.export(args.checkpoint or robot, out, str(model) if model else None)
    print(f"wrote {dest}")
    return 0


def cmd_play(args: argparse.Namespace) -> int:
    from mjx_cascade import play

    model = _policy_args(args, {})
    play.check_display()
    play.play(args.robot, args.checkpoint, model, args.dt, seconds=args.seconds)
    return 0


def cmd_robustness(args: argparse.Namespace) -> int:
    import dataclasses

    from mjx_cascade import progress, robustness

    given = {k: v for k, v in (("axes", args.axes and tuple(args.axes)), ("trials", args.trials),
                               ("seconds", args.seconds), ("push_forces", args.push_forces and tuple(args.push_forces)),
                               ("push_directions", args.push_directions and tuple(args.push_directions)))
             if v is not None}
    sweep = dataclasses.replace(robustness.Sweep(), **given)
    if (args.push_forces or args.push_directions) and "push" not in sweep.axes:
        raise ConfigError("--push-forces and --push-directions need the push axis (--axes push ...)")
    model, out, settings = _simulation_args(args)
    results, _ = robustness.sweep(args.robot, out, sweep, checkpoint_dir=args.checkpoint, model_path=model,
                                  dt=args.dt, impl=args.impl, settings=settings, progress=progress.Report("robustness"),
                                  plot=not args.no_figures)
    if args.json:
        print(json.dumps({k: v for k, v in results.items() if k != "trials"}, indent=2))
    else:
        print(robustness.markdown(results))
        print(f"wrote {out} in {results['wall_clock_s']:.0f} s")
    return 0


def cmd_benchmark(args: argparse.Namespace) -> int:
    from mjx_cascade import _xla, benchmark, profiles, progress, scenario

    model = _policy_args(args, {})
    scenarios = profiles.resolve(args.robot, args.profiles) if args.profiles else \
        [scenario.load(f) for f in args.scenario]
    out = Path(args.out)
    if out.is_dir():
        raise ConfigError(f"--out {out} is a directory; give the result file's name")
    _xla.enable_compilation_cache()
    result = benchmark.walking(args.robot, scenarios, args.profiles or "scenarios", args.checkpoint, model,
                               args.dt, args.simulator, progress.Report("benchmark"))
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1) + "\n")
    r = result["response"]
    print(f"{args.robot} / {result['set']}: passed {result['passed']} of {result['count']}, fell {result['fell']}; "
          + ", ".join(f"{a} settles in {v['median_s']:.2f} s median, {v['worst_s']:.2f} s worst ({v['unsettled']} unsettled)"
                      for a, v in r.items() if v["median_s"] is not None))
    print(f"wrote {out}")
    return 0


def cmd_revise(args: argparse.Namespace) -> int:
    from mjx_cascade import policies

    directory = Path(args.policy)
    if not policies.is_policy_dir(directory):
        raise ConfigError(f"--policy {directory} is not a policy directory (params.npz and record.json)")
    revision = policies.revise(directory, config_lib.parse_assignments(args.set), args.reason, args.date)
    print(json.dumps(revision))
    return 0


if __name__ == "__main__":
    sys.exit(main())
