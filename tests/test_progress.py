"""Progress bars: tqdm, off when asked or when output is not interactive."""
import io

import pytest

from fpk_vibro import VibroImpactSystem, fem, montecarlo
from fpk_vibro.progress import Progress, interactive


def test_progress_is_off_when_not_interactive_and_on_when_asked(capsys):
    assert not interactive()                     # pytest captures stderr: not a terminal
    s = VibroImpactSystem.paper(r=0.92)
    montecarlo.stationary(s, seed=1, n_paths=256, t_sample=20.0)
    fem.transient(s, initial={"mean": (0.1, 0.3), "std": (0.1, 0.2)}, times=[1.0], nx=8)
    assert capsys.readouterr().err == ""
    bar = Progress(True, "test", total=10, unit="point")
    bar._bar.fp = io.StringIO()
    bar._bar.delay = 0
    bar.update(5)
    assert bar._bar.n == 5
    bar.close()
    Progress(False, "x").update(0.5)             # disabled: a no-op


@pytest.mark.parametrize("value, delay", [("0", 0.0), ("0.5", 0.5), ("x", 2.0), ("-1", 2.0),
                                          (None, 2.0)])
def test_the_delay_of_progress_comes_from_the_environment(value, delay):
    """FPK_VIBRO_PROGRESS_DELAY sets when progress shows (0: as each stage starts, what
    the fault tests wait for); anything but a number >= 0 is the default 2 s."""
    import os
    import subprocess
    import sys
    env = {k: v for k, v in os.environ.items() if k != "FPK_VIBRO_PROGRESS_DELAY"}
    if value is not None:
        env["FPK_VIBRO_PROGRESS_DELAY"] = value
    out = subprocess.run([sys.executable, "-c", "import fpk_vibro.progress as p; "
                          "print(p.LINE_DELAY)"], env=env, capture_output=True, text=True,
                         check=True)
    assert float(out.stdout) == delay
