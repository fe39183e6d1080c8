"""Pattern learning: an RBM and a DBN that verify a candidate's corner pattern (issue 7).

``from pipeline.learn import train_verifier, Verifier, PoorReference``

- `pipeline.learn.encoding`: a candidate's corners and contour as a binary code,
  invariant to position, scale, rotation and the H's half-turn symmetry.
- `pipeline.learn.rbm`: Bernoulli RBM (CD-k, persistent CD), and a label-unit RBM
  classified by free energy.
- `pipeline.learn.dbn`: two stacked 100-unit RBMs plus a logistic read-out.
- `pipeline.learn.data`: synthetic candidates from the renderer, as process_frame sees them.
- `pipeline.learn.verifier`: training per reference, threshold, save/load.
- ``python -m pipeline.learn bench --json``: the benchmark.
"""

from pipeline.learn.dbn import DBN
from pipeline.learn.encoding import Encoder
from pipeline.learn.rbm import RBM, RBMClassifier
from pipeline.learn.verifier import PoorReference, Verifier, train_verifier

__all__ = ["DBN", "RBM", "Encoder", "PoorReference", "RBMClassifier", "Verifier", "train_verifier"]
