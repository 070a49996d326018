from conformorph.cli.main import main

if __name__ == "__main__":  # a spawned process (conformorph morph's key pool) imports this
    raise SystemExit(main())
