"""The flat bouncing ball (docs/model.md §1): trajectories and ensembles (``flatball``), its
periodic orbits and Arnold tongues (``tongues``), their continuation in Gamma
(``continuation``) and the high-bounce approximation (``highbounce``)."""
