/* The bare ZeroMQ loop of benchmarks/server.py without Python: a ROUTER server and five DEALER client
 * processes exchange a synchronous cycle's messages (a sense_body and a think to each client, one command
 * back from each), of the sizes the Python loop's msgpack messages have, and simulate nothing. It calls
 * libzmq itself (pyzmq's bundled copy; the few declarations it needs are written out below, so no zmq.h is
 * needed): what the transport costs without Python's per-message path.
 *
 * Build: cc -O2 -o bare_loop bare_loop.c /path/to/libzmq.so -Wl,-rpath,/path/to
 * Run:   ./bare_loop CYCLES      prints "<cycles/s> <CPU ms per cycle, server and clients>"
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

void *zmq_ctx_new(void);
int zmq_ctx_term(void *context);
void *zmq_socket(void *context, int type);
int zmq_close(void *socket);
int zmq_bind(void *socket, const char *endpoint);
int zmq_connect(void *socket, const char *endpoint);
int zmq_setsockopt(void *socket, int option, const void *value, size_t size);
int zmq_getsockopt(void *socket, int option, void *value, size_t *size);
int zmq_send(void *socket, const void *buf, size_t size, int flags);
int zmq_recv(void *socket, void *buf, size_t size, int flags);

enum { ZMQ_DEALER = 5, ZMQ_ROUTER = 6, ZMQ_SNDMORE = 2, ZMQ_LINGER = 17, ZMQ_LAST_ENDPOINT = 32 };
enum { CLIENTS = 5, SENSE_BODY_BYTES = 43, THINK_BYTES = 21, COMMAND_BYTES = 48, ID_BYTES = 256 };

static double seconds(clockid_t clock) {
    struct timespec t;
    clock_gettime(clock, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

static double cpu_seconds(int who) {
    struct rusage u;
    getrusage(who, &u);
    return u.ru_utime.tv_sec + u.ru_stime.tv_sec + (u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

/* A client: answers each think ('T') with a command; ends on 'Q'. */
static int client(const char *endpoint) {
    char buf[512];
    int zero = 0;
    void *context = zmq_ctx_new(), *sock = zmq_socket(context, ZMQ_DEALER);
    zmq_setsockopt(sock, ZMQ_LINGER, &zero, sizeof zero);
    zmq_connect(sock, endpoint);
    memset(buf, 'x', sizeof buf);
    buf[0] = 'I';
    zmq_send(sock, buf, 16, 0);
    for (;;) {
        if (zmq_recv(sock, buf, sizeof buf, 0) < 1)
            continue;
        if (buf[0] == 'Q')
            break;
        if (buf[0] == 'T') {
            buf[0] = 'C';
            zmq_send(sock, buf, COMMAND_BYTES, 0);
        }
    }
    zmq_close(sock);
    zmq_ctx_term(context);
    return 0;
}

static void send_to(void *sock, const char *id, int id_len, char *buf, char kind, int size) {
    buf[0] = kind;
    zmq_send(sock, id, id_len, ZMQ_SNDMORE);
    zmq_send(sock, buf, size, 0);
}

int main(int argc, char **argv) {
    if (argc == 3 && strcmp(argv[1], "client") == 0)
        return client(argv[2]);
    int cycles = argc > 1 ? atoi(argv[1]) : 3000, zero = 0;
    char endpoint[256], ids[CLIENTS][ID_BYTES], id[ID_BYTES], buf[512];
    int id_len[CLIENTS];
    size_t size = sizeof endpoint;
    void *context = zmq_ctx_new(), *sock = zmq_socket(context, ZMQ_ROUTER);
    zmq_setsockopt(sock, ZMQ_LINGER, &zero, sizeof zero);
    if (zmq_bind(sock, "tcp://127.0.0.1:*") != 0 || zmq_getsockopt(sock, ZMQ_LAST_ENDPOINT, endpoint, &size) != 0) {
        fprintf(stderr, "bare_loop: cannot bind a loopback port\n");
        return 1;
    }
    for (int i = 0; i < CLIENTS; i++) {
        if (fork() == 0) {
            execl(argv[0], argv[0], "client", endpoint, (char *)0);
            _exit(1);
        }
    }
    for (int i = 0; i < CLIENTS; i++) {
        id_len[i] = zmq_recv(sock, ids[i], ID_BYTES, 0);
        zmq_recv(sock, buf, sizeof buf, 0);
    }
    memset(buf, 'x', sizeof buf);
    double start = seconds(CLOCK_MONOTONIC), cpu = cpu_seconds(RUSAGE_SELF);
    for (int t = 0; t < cycles; t++) {
        for (int i = 0; i < CLIENTS; i++) {
            send_to(sock, ids[i], id_len[i], buf, 'S', SENSE_BODY_BYTES);
            send_to(sock, ids[i], id_len[i], buf, 'T', THINK_BYTES);
        }
        for (int answered = 0; answered < CLIENTS; answered++) {
            zmq_recv(sock, id, ID_BYTES, 0);
            zmq_recv(sock, buf, sizeof buf, 0);
        }
    }
    double elapsed = seconds(CLOCK_MONOTONIC) - start;
    cpu = cpu_seconds(RUSAGE_SELF) - cpu;
    for (int i = 0; i < CLIENTS; i++)
        send_to(sock, ids[i], id_len[i], buf, 'Q', 8);
    for (int i = 0; i < CLIENTS; i++)
        wait(NULL);
    cpu += cpu_seconds(RUSAGE_CHILDREN);  /* the clients' whole lives: their start-up is a few ms */
    printf("%.1f %.4f\n", cycles / elapsed, cpu / cycles * 1e3);
    zmq_close(sock);
    zmq_ctx_term(context);
    return 0;
}
