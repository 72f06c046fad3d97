"""What the viscera command-line tools share: argument types, scene loading, and user errors.

A user error (a bad option value, a scene MuJoCo refuses, a missing file) is one line on
stderr and a non-zero status, with no traceback: a traceback is about our code, not the
user's input. Anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import pathlib
import sys
import traceback
from collections.abc import Callable, Iterator

INTERRUPTED = 130  # the shell's status for a process ended by SIGINT


class UserError(Exception):
    """Something wrong in what the user gave; reported as one line with exit `status`
    (2 for an option, as argparse does; 1 for an input such as a scene)."""

    def __init__(self, message: str, status: int = 1):
        super().__init__(message)
        self.status = status


def one_line(message: object) -> str:
    """`message` (MuJoCo's compiler messages span lines) on one line."""
    text = ""
    for line in (line.strip() for line in str(message).splitlines()):
        if line:
            text += (" " if not text or text.endswith(":") else "; ") + line
    return text.strip().removeprefix("Error: ")  # MuJoCo's prefix says nothing our "error:" does not


@contextlib.contextmanager
def user_errors(prog: str, verbose: bool = False) -> Iterator[None]:
    """Report a UserError raised in the body as `prog: error: message` and exit with its status;
    Ctrl-C exits with status 130 and one line. `verbose` prints the traceback first."""
    try:
        yield
    except UserError as error:
        if verbose:
            traceback.print_exc()
        print(f"{prog}: error: {error}", file=sys.stderr, flush=True)
        raise SystemExit(error.status) from None
    except KeyboardInterrupt:
        if verbose:
            traceback.print_exc()
        print(f"\n{prog}: interrupted", file=sys.stderr, flush=True)  # newline: past a progress bar
        raise SystemExit(INTERRUPTED) from None


def load_model(path: str | os.PathLike, xml: str | None = None):
    """The MuJoCo model of the scene file `path` (or of `xml`, text read from it); a missing
    file or a scene MuJoCo refuses (e.g. a misspelled config key) is a UserError."""
    import mujoco  # here: importing this module must not load MuJoCo before viscera picks a GL backend

    if xml is None and not os.path.isfile(path):
        raise UserError(f"{path}: no such scene file" if not os.path.exists(path) else f"{path}: not a file")
    try:
        return mujoco.MjModel.from_xml_path(str(path)) if xml is None else mujoco.MjModel.from_xml_string(xml)
    except ValueError as error:  # MuJoCo's parser and compiler, the plugin's config checks
        from viscera.intestine import load_error_message  # MuJoCo's words for a misspelled key, cleaned
        raise UserError(f"{path}: {one_line(load_error_message(error))}") from error


def _number(kind: Callable[[str], float], text: str) -> float:
    try:
        value = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not {'an integer' if kind is int else 'a number'}: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (nan, inf, 0 and negatives refused)."""
    value = _number(float, text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return value


def positive_float_up_to(limit: float, unit: str, minimum: float = 0.0) -> Callable[[str], float]:
    """argparse type: a finite number in (0, limit], and at least `minimum`; the bounds keep
    step counts finite (--duration 1e308, --record-fps 1e-308 would overflow them)."""

    def check(text: str) -> float:
        value = positive_float(text)
        if value > limit:
            raise argparse.ArgumentTypeError(f"must be at most {limit:g} {unit}, got {text!r}")
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be at least {minimum:g} {unit}, got {text!r}")
        return value

    check.__name__ = f"number of {unit}"
    return check


MAX_DURATION_S = 1e6  # simulated seconds: 11.6 days, beyond any run a person waits for
duration = positive_float_up_to(MAX_DURATION_S, "s")


def fraction(text: str) -> float:
    """argparse type: a number from 0 to 1."""
    value = _number(float, text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be from 0 to 1, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    value = _number(int, text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return value


def natural_int(text: str) -> int:
    """argparse type: an integer >= 0 (seeds)."""
    value = _number(int, text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text!r}")
    return value


MAX_SEED = 2 ** 32 - 1  # numpy's RandomState, which the tasks draw their episodes from, takes no more


def seed(text: str) -> int:
    """argparse type: a random seed, an integer from 0 to 2^32 - 1."""
    value = natural_int(text)
    if value > MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be at most 2^32 - 1 = {MAX_SEED}, got {text!r}")
    return value


def seed_range(text: str) -> range:
    """argparse type: seeds A:B, the seeds A to B - 1 (0 <= A < B <= 2^32)."""
    parts = text.split(":")
    try:
        first, end = (int(part) for part in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be A:B, two integers (the seeds A to B - 1), got {text!r}") from None
    if not 0 <= first < end <= MAX_SEED + 1:
        raise argparse.ArgumentTypeError(f"must be A:B with 0 <= A < B <= 2^32, got {text!r}")
    return range(first, end)


def image_size(text: str) -> tuple[int, int]:
    """argparse type: HEIGHTxWIDTH in pixels, each 1 to 4096."""
    try:
        height, width = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be HEIGHTxWIDTH in pixels, e.g. 84x84, got {text!r}") from None
    if not (1 <= height <= 4096 and 1 <= width <= 4096):
        raise argparse.ArgumentTypeError(f"must be HEIGHTxWIDTH, each 1 to 4096 pixels, got {text!r}")
    return height, width


def output_file(*suffixes: str) -> Callable[[str], str]:
    """argparse type: a file to write, ending in one of `suffixes`, in a folder that exists and
    is writable; checked when the command line is read, not after a long run."""

    def check(text: str) -> str:
        path = pathlib.Path(text)
        if path.suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(f"{text!r} must end in {' or '.join(suffixes)}")
        folder = path.parent
        if not folder.is_dir():
            raise argparse.ArgumentTypeError(f"{text!r}: folder {str(folder)!r} does not exist")
        if path.is_dir():
            raise argparse.ArgumentTypeError(f"{text!r} is a folder")
        if not os.access(folder, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
            raise argparse.ArgumentTypeError(f"{text!r}: not writable")
        return text

    check.__name__ = f"{'/'.join(suffixes)} file"  # argparse names the type in some messages
    return check


def save_png(path: str | os.PathLike, rgb) -> None:
    """Write an (H, W, 3) uint8 image as a PNG (Pillow, which meshcat brings)."""
    from PIL import Image
    Image.fromarray(rgb).save(path, format="PNG")


class OneLineParser(argparse.ArgumentParser):
    """argparse, with a user's mistake as one line on stderr (`prog: error: message`, status 2)
    instead of the usage block before it, and a "did you mean" for a misspelled option, command
    or choice; --help still prints the whole help. Subcommand parsers are of this class too."""

    def parse_known_args(self, args=None, namespace=None):
        self._words = list(sys.argv[1:] if args is None else args)  # for hints when a required option is missing
        return super().parse_known_args(args, namespace)

    def error(self, message: str):  # argparse's hook for every parsing mistake
        print(f"{self.prog}: error: {one_line(self.suggest(message))}", file=sys.stderr, flush=True)
        raise SystemExit(2)

    def options(self) -> list[str]:
        return [option for action in self._actions for option in action.option_strings if option.startswith("--")]

    def suggest(self, message: str) -> str:
        """`message` with a "did you mean" for the misspelled word it names, where one is close,
        and for a misspelled option that argparse's message does not name (it took the option for
        a value, or stopped at a missing argument first)."""
        import difflib
        import re
        unknown = re.match(r"unrecognized arguments: (.*)", message)
        if unknown:
            hints = []
            for word in unknown.group(1).split():
                option = word.split("=", 1)[0]
                if option.startswith("--"):
                    hints.append(f"{option}: {self.close_option(option)}")
                elif word.startswith("-"):
                    hints.append(f"{word}: no such option")
            if hints:
                return f"unrecognized arguments: {unknown.group(1)} ({'; '.join(hints)}; --help lists them)"
            return message
        # Python 3.12.8 and later name the choices unquoted, earlier versions quoted
        choice = re.match(r"argument (\S+): invalid choice: '?(.*?)'? \(choose from (.*)\)$", message)
        if choice:
            listed = choice.group(3)
            choices = re.findall(r"'([^']*)'", listed) if listed.startswith("'") else listed.split(", ")
            close = difflib.get_close_matches(choice.group(2), choices, n=1, cutoff=0.6)
            hint = f"did you mean {close[0]!r}? " if close else ""
            message = (f"argument {choice.group(1)}: invalid choice {choice.group(2)!r}: {hint}"
                       f"choose from {', '.join(choices)}")
        option = self.unknown_option()
        return f"{message} ({option}: {self.close_option(option)})" if option else message

    def close_option(self, option: str) -> str:
        """"did you mean --x?" for the option closest to `option`, or "no such option"."""
        import difflib
        close = difflib.get_close_matches(option, self.options(), n=1, cutoff=0.6) if option.startswith("--") else []
        return f"did you mean {close[0]}?" if close else "no such option"

    def unknown_option(self) -> str | None:
        """The first word given that looks like an option this parser does not have (not a
        negative number, not an abbreviation of one it has)."""
        import re
        known = self.options() + ["-h"]
        for word in getattr(self, "_words", []):
            option = word.split("=", 1)[0]
            if word == "--":
                return None  # what follows is positional
            if option.startswith("-") and option != "-" and not re.fullmatch(r"-[\d.]+(e-?\d+)?", option) \
                    and not any(k.startswith(option) for k in known):
                return option
        return None


def check_unknown(parser: argparse.ArgumentParser, unknown: list[str]) -> None:
    """parse_known_args's leftovers are the subcommand's mistake: its one line."""
    if unknown:
        parser.error(f"unrecognized arguments: {' '.join(unknown)}")


def port(text: str) -> int:
    """argparse type: a TCP/UDP port, 1 to 65535."""
    value = _number(int, text)
    if not 1 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be a port from 1 to 65535, got {text!r}")
    return value


class PolicyChoices(tuple):
    """argparse choices for --policy: the policy kinds it lists, or a policy file's path (one
    ending in .npz or holding a path separator: viscera.policy_file.is_path), checked when it
    is loaded. Anything else gets argparse's own "invalid choice" line, naming the kinds."""

    def __contains__(self, value) -> bool:
        from viscera.policy_file import is_path
        return tuple.__contains__(self, value) or (isinstance(value, str) and is_path(value))


def input_file(text: str) -> str:
    """argparse type: a file that exists (its contents are checked by whoever reads it)."""
    if not os.path.exists(text):
        raise argparse.ArgumentTypeError(f"{text!r}: no such file")
    if os.path.isdir(text):
        raise argparse.ArgumentTypeError(f"{text!r} is a folder")
    return text
