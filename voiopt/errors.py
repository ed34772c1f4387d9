"""The one exception family users see: a one-line message naming the field and the value."""


class VoioptError(ValueError):
    """Bad input: an instance, a plan, an option. The CLI prints it as one line, exit 2."""


class InstanceError(VoioptError):
    """An instance file or dict that breaks a rule of MODEL.md section 1."""


class PlanError(VoioptError):
    """A plan that breaks a rule of MODEL.md section 3."""


class OptionError(VoioptError):
    """An unknown method or objective, or a bad solver option."""


class InstanceWarning(UserWarning):
    """An instance that is legal but likely a mistake (a sensor given twice): one line on the
    command line's stderr."""


class MemoryLimitError(OptionError):
    """The work would pass the memory limit before it has any plan to return."""


def first_line(text, fallback: str = "", limit: int | None = 200) -> str:
    """The first line of a message (another library's, over several lines), at most ``limit``
    characters; ``fallback`` if it has none (an exception without words: its type's name)."""
    return (str(text).strip().splitlines() or [fallback])[0][:limit]


def check_seed(seed) -> None:
    """A seed, of a generator or a randomised method: an integer >= 0 (numpy's generators take
    no other)."""
    try:
        ok = not isinstance(seed, bool) and seed.__index__() >= 0  # int, numpy's integers
    except (AttributeError, TypeError):
        ok = False
    if not ok:
        raise OptionError(f"seed: must be an integer >= 0, got {seed!r}")


def check_stream_seeds(first: int, count: int = 1, what: str = "seed") -> None:
    """Q-learning's random stream keeps 64 bits of its seed (qlearning._rng.seed_state): the
    seeds first..first+count-1 must fit, or seed + 2**64 would silently rerun seed's stream."""
    if first + count - 1 >= 2**64:
        got = repr(first) if count == 1 else f"the seeds {first}..{first + count - 1} of --seeds {count}"
        raise OptionError(f"{what}: must be below 2**64 (Q-learning's random stream has 64 bits), got {got}")


MAX_EPISODES = 10**12  # Q-learning's R_max: about two months of training at the paper's size; past it, a typo


def check_episodes(episodes, name: str = "episodes") -> None:
    """Q-learning's episodes R_max: an integer from 1 to MAX_EPISODES (a huge one is shown in
    three digits, not a hundred)."""
    try:
        n = None if isinstance(episodes, bool) else episodes.__index__()  # int, numpy's integers
    except (AttributeError, TypeError):
        n = None
    if n is None or not 1 <= n <= MAX_EPISODES:
        big = n is not None and n > MAX_EPISODES and len(str(n)) > 20  # a hundred digits say no more than 1e+100
        got = f"{float(n):.3g}" if big else repr(n if n is not None else episodes)
        raise OptionError(f"{name}: must be an integer from 1 to {MAX_EPISODES:.0e}, got {got}")


class MissingExtraError(VoioptError):
    """An optional dependency is not installed; the message names the pip command."""

    def __init__(self, module: str, extra: str):
        super().__init__(
            f"this needs the optional package '{module}': in a clone, .venv/bin/pip install -e '.[{extra}]' "
            f"(an installed voiopt: pip install 'voiopt[{extra}]')"
        )


class WorkerDied(RuntimeError):
    """A pool worker of a sweep ended without handing back its run (the CLI exits 1)."""
