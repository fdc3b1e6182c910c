"""Read-out heads: optional, benchmark-specific plug-ins around the paper's core encoder.

The paper's model is the
appearance branch, the question-conditioned temporal branch, cross-attention fusion and the projector. The heads
here read a verdict from the frozen encoder's output and write it into the tokens: the clip reader (a one-video
prompt's trait levels), the comparator (which video a comparison picks), the name matcher (which video is which
listed option) and the option marks (the matcher's verdict on the option names). All share one interface
(:mod:`.base`), meet the core model through one hook (:mod:`.hook`), are fitted when Stage II starts, and give Stage
II out-of-fold readings (:mod:`.crossfit`), so training never sees in-sample, near-gold verdicts. Report them beside
the plain model.
"""

from tacreasoner.model.heads.base import READINGS, HeadRows, ReadoutHead
from tacreasoner.model.heads.clip_reader import ClipReader
from tacreasoner.model.heads.cross_video import ComparatorHead, CrossVideoFusion, NameMatcherHead
from tacreasoner.model.heads.crossfit import CrossFit, crossfit, object_folds
from tacreasoner.model.heads.hook import HeadModules, ReadoutHeads, build_heads
from tacreasoner.model.heads.option_marks import loud_option_marks, mark_options

__all__ = ["READINGS", "ClipReader", "ComparatorHead", "CrossFit", "CrossVideoFusion", "HeadModules", "HeadRows",
           "NameMatcherHead", "ReadoutHead", "ReadoutHeads", "build_heads", "crossfit", "loud_option_marks",
           "mark_options", "object_folds"]
