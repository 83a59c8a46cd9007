# Sourced by the shell tests that stop a render of their own in the
# background. finish PID: waits for PID, at most 120 s; one still running
# then is killed and counted a failure (with the caller's bad, and the
# start of its $T/err), so that a hang fails the test instead of stopping
# it. Returns PID's status. A job that has ended stays a zombie until it is
# waited for, so /proc's state tells.
finish() {
    n=0
    while [ -e "/proc/$1" ] && [ "$(cut -d' ' -f3 "/proc/$1/stat" 2>/dev/null)" != Z ]; do
        if [ "$n" -ge 1200 ]; then
            bad "pid $1 still running after 120 s: killed ($(head -c 300 "$T/err"))"
            kill -s KILL "$1" 2>/dev/null
            break
        fi
        sleep 0.1
        n=$((n + 1))
    done
    wait "$1"
}
