from tendrilkit.cli import main

raise SystemExit(main())
