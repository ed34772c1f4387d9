"""VoI-Lib, the certified benchmark library: instances, certificates and scoring (library)."""
