"""``bnerr eval DIR`` and what it alone needs: the command (:mod:`.command`), the frame folder it
reads (:mod:`.frame_folder`: the manifest, the layout, every file checked before anything is
written) and the measuring of its methods as ``bnerr bench`` measures a strategy
(:mod:`.evaluate`). docs/EVAL.md is the user's guide."""

from benchmarks.commands.eval.command import register, run

__all__ = ["register", "run"]
