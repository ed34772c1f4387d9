"""The voiopt command: thin, it parses arguments and calls the API (main), with the bench and import-solution commands (bench)."""
