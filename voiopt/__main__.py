from voiopt.cli import run

run()
