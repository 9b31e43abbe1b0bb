"""Progress bars: tqdm, off when asked or when output is not interactive."""
import io

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
