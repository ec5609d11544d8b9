"""`dcjax sample`: posterior draws of a saved result's parameters (NUTS through the simulator)."""

from ...analysis.plotting import corner
from ...fitting.vector import unit_of
from ...io.files import file_sha256
from ..common import add_output_options, add_result_options, saved_result
from ..output import announce, output_folder
from ..values import priors


def add_parser(sub) -> None:
    m = sub.add_parser("sample", help="posterior draws of a saved result's parameters (NUTS through the simulator), with R-hat and ESS")
    m.add_argument("result", help="result.json of a fit (its data files are read again)")
    m.add_argument("--draws", type=int, default=1000, help="draws per chain after warmup (default 1000)")
    m.add_argument("--chains", type=int, default=4, help="chains, run side by side (default 4)")
    m.add_argument("--warmup", type=int, default=1000, help="warmup steps per chain: step size and dense mass matrix (default 1000)")
    m.add_argument("--seed", type=int, default=0, help="random seed (same seed, same draws)")
    add_output_options(m, "out", "posterior.npz and corner.png")
    add_result_options(m, data=True)
    m.add_argument(
        "--prior",
        type=priors,
        action="append",
        default=[],
        metavar="NAME=SPEC",
        help="a parameter's own prior within its range instead of the uniform one: normal(MEAN,SD), lognormal(MEDIAN,SIGMA) "
        "or halfnormal(SD), e.g. for the DC motor --prior 'J=lognormal(1e-4,0.5)' (repeatable)",
    )


def run(args) -> int:
    """The table (posterior beside the linearised 90 % intervals), posterior.npz and corner.png in --out."""

    res = saved_result(args)
    given = {k: v for d in args.prior for k, v in d.items()}
    with output_folder(args, lambda f: [f / "posterior.npz"], "an earlier posterior.npz") as folder:
        out = folder.path
        post = res.sample(draws=args.draws, chains=args.chains, warmup=args.warmup, seed=args.seed, priors=given)
        u = res.uncertainty().uncertainties
        assert u is not None
        print(post.table(u.intervals(post.names)))
        announce(folder)
        post.save(out / "posterior.npz", result_sha256=file_sha256(args.result))
        corner(post, out / "corner.png", units={n: unit_of(n, res.model) for n in post.names})
    bad = [n for n in post.names if not post.rhat[n] <= 1.01 or not post.ess_bulk[n] >= 400]
    if bad:
        print(
            f"warning: R-hat above 1.01 or bulk ESS below 400 for {', '.join(bad)}: more --draws/--warmup, or a posterior "
            "the sampler does not mix over (see corner.png)"
        )
    if post.divergences:
        print(f"warning: {post.divergences} divergent transitions: the draws may miss part of the posterior")
    print(f"wrote {out / 'posterior.npz'} and {out / 'corner.png'}")
    return 0
