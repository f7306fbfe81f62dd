"""``auvdock cache``: the compiled-solver cache."""

from __future__ import annotations

import typer

from auvdock.cli.app import app, console

cache_app = typer.Typer(help="The compiled-solver cache (see auvdock.runtime.codegen).", no_args_is_help=True)
app.add_typer(cache_app, name="cache")


@cache_app.command("info")
def cache_info() -> None:
    """Where the compiled solvers are, how many, how large; and whether compiling is possible."""
    from auvdock.runtime.codegen import cache_dir, cache_entries, compile_mode, find_compiler

    entries = cache_entries()
    total = sum(n for _, n in entries)
    console.print(f"cache: {cache_dir()}", markup=False, highlight=False)
    console.print(f"compiled solvers: {len(entries)} ({total / 1e6:.1f} MB)")
    for p, n in entries:
        console.print(f"  {p.name}  {n / 1e6:.1f} MB", markup=False)
    cc = find_compiler()
    console.print(
        f"compiler: {cc or 'none found (solvers run uncompiled)'}; AUVDOCK_COMPILE={compile_mode()}"
    )


@cache_app.command("clear")
def cache_clear() -> None:
    """Remove every compiled solver from the cache."""
    from auvdock.runtime.codegen import cache_dir, clear_cache

    n = clear_cache()
    console.print(f"removed {n} compiled solver{'s' if n != 1 else ''} from {cache_dir()}", markup=False)
