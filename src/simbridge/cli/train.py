"""`simbridge train`: ARS on a simbridge environment, here or on a Ray cluster (`--ray`)."""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

__all__ = ["add_parser"]


def _env_arg(text: str) -> tuple[str, Any]:
    import yaml

    key, sep, value = text.partition("=")
    if not sep or not key.isidentifier():
        raise argparse.ArgumentTypeError(
            f"--env-arg {text!r}: expected NAME=VALUE, e.g. action=joint_delta"
        )
    return key, yaml.safe_load(value)


def _success(text: str) -> float | None:
    if text.lower() == "none":
        return None
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"--target-success {text!r}: expected 0..1 or none")
    return value


def run_train(args: argparse.Namespace) -> int:
    import gymnasium as gym

    from simbridge.errors import GymError
    from simbridge.gym import ENV_IDS, ARSConfig
    from simbridge.gym.ars import CurvePoint
    from simbridge.progress import Ticker, elapsed

    if args.env not in ENV_IDS:
        raise GymError(f"unknown environment {args.env!r}; simbridge has {', '.join(ENV_IDS)}")
    spec = gym.spec(args.env)
    max_steps = args.max_steps or spec.max_episode_steps
    if not max_steps or max_steps < 1:
        raise GymError(f"--max-steps must be >= 1 (the env gives {spec.max_episode_steps})")
    config = ARSConfig(
        directions=args.directions,
        top=args.top or max(1, args.directions // 2),
        step_size=args.step_size,
        noise=args.noise,
        iterations=args.iterations,
        eval_episodes=args.eval_episodes,
        eval_every=args.eval_every,
        target_success=args.target_success,
        time_budget_s=args.time_budget,
        seed=args.seed,
        keys=tuple(args.keys.split(",")) if args.keys else None,
    )
    env_kwargs = dict(args.env_arg)

    latest: list[CurvePoint] = []

    def show(point: CurvePoint) -> None:
        latest[:] = [point]
        ticker.print(
            f"iteration {point.iteration:4d}: success {point.success_rate:.2f}, "
            f"return {point.mean_return:8.3f}, {point.env_steps:,} env steps, "
            f"{point.wall_s:.1f} s"
        )

    start = time.perf_counter()

    def status() -> str:  # between the evaluations' lines, which may be minutes apart
        now = f"training {args.env}: {elapsed(time.perf_counter() - start)}"
        if not latest:
            return now
        point = latest[0]
        return (
            f"{now}; last evaluated at iteration {point.iteration} of {config.iterations}: "
            f"success {point.success_rate:.2f}"
        )

    where: dict[str, Any] = {"ray": None}
    ticker = Ticker(status)
    with ticker:
        if args.ray:
            from simbridge.cluster import train_ars_on_ray

            run = train_ars_on_ray(
                args.env,
                max_steps,
                config,
                address=args.ray,
                workers=args.workers,
                env_kwargs=env_kwargs,
                progress=show,
            )
            result = run.result
            where = {
                "ray": args.ray,
                "worker_nodes": run.worker_nodes,
                "episodes_per_node": run.episodes_per_node,
                "busy_s_per_node": run.busy_s_per_node,
                "batches_s": run.batches_s,
                "overhead_s": run.overhead_s,
                "cluster_cpus": run.cluster_cpus,
            }
            nodes = len(set(run.worker_nodes))
            placed = (
                f" on {len(run.worker_nodes)} Ray workers, {nodes} node(s) (Ray's overhead "
                f"{run.overhead_s:.1f} s of {run.batches_s:.1f} s waiting for episodes)"
            )
        else:
            from simbridge.cluster import make_vector
            from simbridge.gym import train_ars

            vec = make_vector(args.env, 2 * config.directions, max_steps, env_kwargs)
            try:
                result = train_ars(vec, max_steps, config, progress=show)
            finally:
                vec.close()
            placed = ""
    wall = time.perf_counter() - start
    last = result.curve[-1]
    print(
        f"trained {args.env}{placed}: success {last.success_rate:.2f} after "
        f"{last.iteration} iterations, {last.env_steps:,} env steps, {wall:.1f} s"
    )
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        result.policy.save(out / "policy.npz")
        record = {
            "env": args.env,
            "env_kwargs": env_kwargs,
            "max_steps": max_steps,
            "config": asdict(config),
            "curve": [asdict(point) for point in result.curve],
            "wall_s": wall,
            **where,
        }
        (out / "run.json").write_text(json.dumps(record, indent=2) + "\n")
        print(f"policy: {out / 'policy.npz'}, run: {out / 'run.json'}")
    return 0


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "train",
        help="train a linear policy with ARS on a simbridge environment (optionally on Ray)",
        description="Augmented random search on a simbridge/* environment: one vector env "
        "here, or the rollouts on Ray actors with --ray. The same seed gives the same "
        "policy either way.",
    )
    p.add_argument("env", help="environment id, e.g. simbridge/Reach-v0")
    p.add_argument("--out", help="folder for policy.npz and run.json (curve, where it ran)")
    p.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="run the rollouts on the Ray cluster at HOST:PORT ('auto': the one `ray start` "
        "runs on this machine); needs `pip install 'simbridge[ray]'`",
    )
    p.add_argument("--workers", type=int, help="Ray workers (default: one per CPU of the cluster)")
    p.add_argument("--max-steps", type=int, help="episode length (default: the env's)")
    p.add_argument("--directions", type=int, default=8, help="directions a step (default 8)")
    p.add_argument("--top", type=int, help="best directions used (default half)")
    p.add_argument("--step-size", type=float, default=0.1, help="default 0.1")
    p.add_argument("--noise", type=float, default=0.1, help="default 0.1")
    p.add_argument("--iterations", type=int, default=60, help="at most (default 60)")
    p.add_argument("--eval-every", type=int, default=5, help="iterations (default 5)")
    p.add_argument("--eval-episodes", type=int, default=32, help="default 32")
    p.add_argument(
        "--target-success",
        type=_success,
        default=0.9,
        help="stop at this evaluated success rate (default 0.9; 'none': never)",
    )
    p.add_argument("--time-budget", type=float, help="stop after this many seconds")
    p.add_argument("--seed", type=int, default=0, help="default 0")
    p.add_argument("--keys", help="observation entries the policy reads, comma separated")
    p.add_argument(
        "--env-arg",
        type=_env_arg,
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="keyword for the env (YAML value), e.g. action=joint_delta; repeatable",
    )
    p.set_defaults(func=run_train)
