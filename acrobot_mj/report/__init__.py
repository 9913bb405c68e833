"""What the package shows: figures (:mod:`.plots`), MP4 videos (:mod:`.video`) and the validation
report (:mod:`.validation`: the dynamics against MuJoCo, and the physics references)."""
