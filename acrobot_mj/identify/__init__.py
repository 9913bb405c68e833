"""Models of the acrobot identified from data, beside the equations of :mod:`acrobot_mj.physics`:
its lumped parameters told the equations' structure (:mod:`~acrobot_mj.identify.lumped`), or a
generic model of one decision told nothing of them (:mod:`~acrobot_mj.identify.library`, its
terms and fits). :mod:`acrobot_mj.control` plans and tracks on either."""
