from scdp.cli import main

raise SystemExit(main())
