"""The command line's side of policies (MODEL.md section 11): ``voiopt solve --policy-out``, and
a policy's result naming the policy it saved beside itself (RESULT.policy.json by default)."""

from __future__ import annotations

from pathlib import Path

from voiopt.errors import OptionError
from voiopt.runtime.files import check_output_file

POLICY_OPTIONS = ("samples", "ir_samples", "planner")  # passed to the method only where given


def add_policy_option(parser):
    parser.add_argument("--policy-out", default=None, metavar="POLICY",
                        help="where a policy method saves its policy (default: RESULT.policy.json beside -o)")
    parser.add_argument("--samples", type=int, default=None, metavar="K",
                        help="replan, qlearning on lossy links: coupled scenarios of a Monte Carlo value (default 1000)")
    parser.add_argument("--ir-samples", type=int, default=None, metavar="K",
                        help="replan, qlearning on lossy links: scenarios of the information-relaxation bound (default 0: none)")
    parser.add_argument("--planner", default=None, choices=("dp", "beam"), help="replan: the lossless solver (default dp)")
    return parser


def policy_path(args) -> str | None:
    """Where a policy's result saves its policy, checked before any work: --policy-out, else
    RESULT.policy.json beside -o for a policy method, else nowhere."""
    from voiopt.core.result import beside
    from voiopt.solvers import POLICY_METHODS

    if args.policy_out is not None and args.method not in POLICY_METHODS:
        raise OptionError(f"--policy-out: method {args.method!r} returns a plan, not a policy (-o keeps its result; "
                          f"the policy methods: {', '.join(sorted(POLICY_METHODS))})")
    derived = args.output is not None and args.method in POLICY_METHODS  # only a policy method saves one
    path = args.policy_out or (beside(args.output) if derived else None)
    if path is not None:
        check_output_file(path, "--policy-out", inputs=[("INSTANCE", args.instance), ("-o", args.output)])
    return path


def policy_note(path: str | None, result) -> str | None:
    """A line for stderr where a policy is lost, or a --policy-out is left unwritten."""
    if getattr(result, "policy", None) is None:
        return None if path is None else (f"note: --policy-out: the result is a plan, not a policy (no lossy links); "
                                          f"nothing written to {path}")
    if path is None:
        return "note: the policy is not kept: -o RESULT.json saves it beside the result, as RESULT.policy.json"
    return None


def save_policy(path: str | None, result):
    """Save a policy result's policy at ``path`` (atomically), named in ``result.solver``."""
    policy = getattr(result, "policy", None)
    if policy is not None and path is not None:
        policy.save(path)
        result.solver["policy_file"] = Path(path).name
    return result
