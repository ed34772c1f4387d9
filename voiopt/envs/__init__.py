"""The environments' shared parts: the checks both envs make (checks). The documented env
modules stay voiopt.env (Gymnasium) and voiopt.pz_env (PettingZoo)."""
