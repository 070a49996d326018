from conformorph.cli.main import main

raise SystemExit(main())
