"""Rewrites of a scene file's TOML text, line by line, for the run
scripts that sweep an option (dpm_branching.sh, dpm_kalthoff.sh): each
touches the first line that starts with its key."""
import re


def put(t, key, value):
    """The line `key = ...` set to `key = value`."""
    return re.sub(rf"^{key} = .*$", lambda m: f"{key} = {value}", t, count=1, flags=re.M)


def after(t, anchor, key, value):
    """A line `key = value` added after the line `anchor = ...`."""
    return re.sub(rf"^({anchor} = .*)$", lambda m: f"{m.group(1)}\n{key} = {value}", t, count=1, flags=re.M)


def drop(t, key):
    """Every line `key = ...` removed."""
    return re.sub(rf"^{key} = .*\n", "", t, flags=re.M)


def initiation_box(t, centre, r):
    """The damage initiation box set to `centre` ± r (2D)."""
    (x, y) = centre
    return re.sub(r"initiation = \{ shape = \{ type = \"box\", min = \[[^]]*\], max = \[[^]]*\] \}",
                  lambda m: f"initiation = {{ shape = {{ type = \"box\", min = [{x - r!r}, {y - r!r}], max = [{x + r!r}, {y + r!r}] }}", t)
