"""The paper's reproduction, on top of the library: it uses only the public API and the library.

* :mod:`~dd_contact.paper.flops`: the paper's operation-count (FLOPs) model of every algorithm
  (method.md 6-7, ``docs/cost.md``);
* :mod:`~dd_contact.paper.models`: the paper's two examples, the parallelepiped and the
  multi-pin joint, as finite element models (``docs/models.md``);
* :mod:`~dd_contact.paper.verify`: the verification cases against closed forms
  (``dd-contact verify``);
* :mod:`~dd_contact.paper.compare`: the algorithms run on one scene and compared with FULL
  (``docs/compare.md``);
* :mod:`~dd_contact.paper.examples`: example scenes of the benchmarks.

Import the one you need (``from dd_contact.paper import flops``); the package imports none of
them, so the library never pays for the paper.
"""
