"""The one step that updates VoI-Lib's shipped certificates (a maintainer's, in a source
checkout): ``merge`` takes what ``bench certify`` wrote into a folder and refuses any
certificate weaker than the shipped one, or in disagreement with it (docs/voilib.md)."""

from __future__ import annotations

import os
from pathlib import Path

from voiopt.errors import OptionError
from voiopt.objectives import OBJECTIVES
from voiopt.runtime.files import read_json, write_json_atomic
from voiopt.voilib import library as voilib
from voiopt.voilib import lossy
from voiopt.voilib.certificates import provenance, same, verdict


def source_file(source: str | os.PathLike) -> Path:
    """A certificates.json, or the folder holding one (``bench certify --into``'s)."""
    p = Path(source)
    return p / "certificates.json" if p.is_dir() else p


def check_policy(folder: Path, name: str, objective: str, cert: dict, inst) -> None:
    """A lossy certificate's stored optimal policy (``policy_file`` under ``folder``) is of its
    instance, and its exact value, computed again here, is the certificate's value."""
    from voiopt.core.policy import Policy
    from voiopt.core.policy_value import exact_value

    if cert.get("policy_file") is None:
        return
    path = folder / cert["policy_file"]
    if not path.is_file() or lossy.file_hash(path) != cert.get("policy_sha256"):
        raise OptionError(f"{path}: {name} {objective}: policy_file: missing, or not the policy its sha256 names; "
                          "nothing merged")
    policy = Policy.load(path)
    value = exact_value(policy, objective, max_states=len(policy.table) + 1)
    if voilib.instance_hash(policy.instance) != voilib.instance_hash(inst) or value is None \
            or not same(value, cert["value"]):
        raise OptionError(f"{path}: {name} {objective}: the stored policy is worth {value!r}, not the certified "
                          f"{cert['value']!r} (or is of another instance); nothing merged")


def merge(source: str | os.PathLike, target: str | os.PathLike | None = None) -> tuple[Path, list[str]]:
    """Merge the certificates of ``source`` (a certificates.json that ``bench certify`` wrote,
    or its folder) into ``target`` (default: the shipped certificates.json, a maintainer's
    step in a source checkout). Every entry of ``source`` must be of a library instance (by
    sha256) and of this version; a certificate that is weaker than the one in ``target``, or
    disagrees with it, refuses the whole merge, naming it, and nothing is written. Returns the
    path written and the entries replaced or added ("name objective")."""
    src = source_file(source)
    new = read_json(src, OptionError)
    dest = Path(str(voilib.DATA / "certificates.json")) if target is None else Path(target)
    old = read_json(dest, OptionError) if dest.exists() else {"version": voilib.VERSION, "instances": {}}
    if not isinstance(new, dict) or not isinstance(new.get("instances"), dict):
        raise OptionError(f"{src}: not a certificates file (no instances)")
    if new.get("version") != voilib.VERSION:
        raise OptionError(f"{src}: version: {new.get('version')!r} is not VoI-Lib's {voilib.VERSION!r}: certificates "
                          "of another version are not merged")
    lib = voilib.instances()
    changed = []
    for name, entry in new["instances"].items():
        if name not in lib or entry.get("sha256") != voilib.instance_hash(lib[name]):
            raise OptionError(f"{src}: {name}: is no VoI-Lib {voilib.VERSION} instance (by name and sha256)")
        kept = old["instances"].setdefault(name, {"sha256": entry["sha256"], "certificates": {}})
        for objective, cert in entry["certificates"].items():
            if objective not in OBJECTIVES:
                raise OptionError(f"{src}: {name}: {objective!r} is no objective")
            shipped = kept["certificates"].get(objective)
            why = None if shipped is None else verdict(objective, shipped, cert)
            if why is not None:
                raise OptionError(f"{src}: {name} {objective}: {why}; nothing merged")
            if shipped != cert:
                kept["certificates"][objective] = {**cert, "provenance": provenance(cert)}
                changed.append(f"{name} {objective}")
    old["instances"] = {n: old["instances"][n] for n in lib if n in old["instances"]}  # the library's order
    old["version"] = voilib.VERSION
    if changed:
        merged = {n: {"certificates": {o: c for o, c in e["certificates"].items() if f"{n} {o}" in changed}}
                  for n, e in new["instances"].items()}
        for name, entry in merged.items():
            for objective, cert in entry["certificates"].items():
                check_policy(src.parent, name, objective, cert, lib[name])
        lossy.copy_policies(merged, src.parent, dest.parent)  # before the certificates that name them
        write_json_atomic(dest, old)
    return dest, changed
