import sys
from pathlib import Path

# helpers shared by the alignment tests (import mode is importlib, so add the folder explicitly)
sys.path.insert(0, str(Path(__file__).parent))
