"""Warm-up finds numba's cache of a kernel where numba writes it, from public information only."""

import os
import subprocess
import sys
import textwrap

import pytest

from abb_ros.model import jit

needs_numba = pytest.mark.skipif(not jit.enabled(), reason='numba not available')

KERNEL = textwrap.dedent('''
    import numba

    @numba.njit(cache=True)
    def twice(x):
        return 2.0 * x
    ''')

PROBE = textwrap.dedent('''
    import sys
    sys.path.insert(0, sys.argv[1])
    import tiny_kernel
    from abb_ros.model.warmup import kernel_cache_dir
    assert tiny_kernel.twice(1.5) == 3.0
    print(kernel_cache_dir(tiny_kernel.__file__))
    ''')


def _cached_where(tmp_path, **env):
    """Compile a cache=True kernel in a fresh process; return (the directory warm-up names for
    its source, the directories numba wrote index files to under tmp_path)."""
    src = tmp_path / 'src'
    src.mkdir()
    (src / 'tiny_kernel.py').write_text(KERNEL, encoding='utf-8')
    run_env = {k: v for k, v in os.environ.items() if k != 'NUMBA_CACHE_DIR'}
    run_env.update(env)
    result = subprocess.run([sys.executable, '-c', PROBE, str(src)], env=run_env,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    named = os.path.realpath(result.stdout.strip())
    written = {os.path.realpath(p.parent) for p in tmp_path.rglob('tiny_kernel.twice-*.nbi')}
    return named, written


@needs_numba
def test_warmup_names_the_in_tree_pycache_numba_writes_to(tmp_path):
    """A writable source directory: numba writes beside the source, and warm-up says so."""
    named, written = _cached_where(tmp_path)
    assert written == {named} and named.endswith('__pycache__')


@needs_numba
def test_warmup_names_the_numba_cache_dir_sub_directory_numba_writes_to(tmp_path):
    """$NUMBA_CACHE_DIR set: numba writes in its sub-directory for the source directory (not
    beside the source), and warm-up computes that same directory."""
    named, written = _cached_where(tmp_path, NUMBA_CACHE_DIR=str(tmp_path / 'cache'))
    assert written == {named}
    assert named.startswith(os.path.realpath(tmp_path / 'cache'))
