import sys,time
t0=time.time()
for l in sys.stdin:
    print(f"{time.time()-t0:8.1f} {l}", end="", flush=True)
